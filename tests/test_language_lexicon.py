"""Surface forms (lexicon), answers in words and the unknown-word normaliser (typos, compounds)."""

from __future__ import annotations

from po3d_ppl import ontology
from po3d_ppl.language import lexicon as lx
from po3d_ppl.language.answer_words import add_answer_words, answer_words
from po3d_ppl.language.seq2seq.calibrate import expected_calibration_error, perturb
from po3d_ppl.language.seq2seq.normalise import Normaliser, edits1


def test_every_shape_and_part_value_has_words():
    for value in ontology.SHAPE_VALUES:
        assert lx.shape_forms(value)
    for value in ontology.CANONICAL_PARTNAME_VALUES:
        assert lx.part_forms(value) or all(lx.part_forms_for_category(value, c) for c in ontology.CATEGORIES)


def test_spellings_raw_readable_spaced_joined_and_plurals():
    assert "school bus" in lx.shape_forms("school") and "schoolbus" in lx.shape_forms("school")
    assert {"rearlight", "rear light"} <= set(lx.part_forms("rearlight"))
    assert {"side stand", "sidestand"} <= set(lx.part_forms("side_stand"))
    assert "back left wheel" in lx.part_forms("back_left_wheel") and "rear left wheel" in lx.part_forms(
        "back_left_wheel")
    assert lx.plural_forms("bus") == ("buses", "buss")  # the public generator's plural quirk
    assert lx.plural_forms("road bike") == ("road bikes",)


def test_a_spelling_two_values_share_is_decided_by_the_category():
    # the car's head_light_left and the motorbike's headlight_left: "left headlight" is either
    assert "left headlight" not in lx.part_forms("head_light_left")
    assert "left headlight" in lx.part_forms_for_category("head_light_left", "car")
    assert "left headlight" not in lx.part_forms_for_category("head_light_left", "motorbike")
    assert "left head light" in lx.part_forms_for_category("headlight_left", "motorbike")


def test_answer_words():
    assert answer_words("school", "Shape") == "school bus"
    assert answer_words("car", "Shape") == "car"
    assert answer_words("wheel_back_left", "Partname") == "back left wheel"
    assert answer_words(True, "Bool") == "yes" and answer_words(False, "Bool") == "no"
    assert answer_words(3, "Integer") == "3"
    assert answer_words("left", "Direction") == "left" and answer_words("left_pose", "Pose") == "left"
    assert answer_words("gray", "Color") == "gray"
    out = add_answer_words({"answer_type": "Shape", "top": "road", "probs": [["road", 0.9], ["suv", 0.1]]})
    assert out["top_words"] == "road bike" and out["words"] == [["road", "road bike"], ["suv", "suv"]]


def test_normaliser_corrects_typos_splits_and_joins():
    norm = Normaliser({"red": 50, "car": 90, "cars": 40, "behind": 30, "school": 20, "bus": 60, "wheel": 10,
                       "rear": 10, "sidestand": 3, "the": 99, "how": 9, "many": 9, "are": 9})
    out = norm(["how", "many", "redd", "carz", "are", "behnd", "the", "schoolbus"])
    assert out.words == ("how", "many", "red", "car", "are", "behind", "the", "school", "bus")
    assert ("redd", "red") in out.corrections and ("schoolbus", "school bus") in out.corrections
    assert norm(["side", "stand"]).words == ("sidestand",)
    assert norm(["zorblax"]).unknown == ("zorblax",)
    assert norm(["xy"]).unknown == ("xy",)  # too short to correct safely
    assert "car" in edits1("cra") and "car" in edits1("cr")


def test_calibration_helpers():
    import numpy as np

    rng = np.random.default_rng(0)
    texts = {perturb("What color is the big red car?", rng) for _ in range(30)}
    assert "What color is the big red car?" in texts and len(texts) > 5
    assert expected_calibration_error([1.0, 1.0], [True, True]) < 1e-5
    assert abs(expected_calibration_error([0.9, 0.9], [True, False]) - 0.4) < 1e-9


def test_other_names_of_parts_and_shapes():
    from po3d_ppl.language import lexicon as lx

    assert "boot" in lx.part_forms("trunk") and "kickstand" in lx.part_forms("side_stand")
    assert "rear number plate" in lx.part_forms("back_license_plate")
    assert "left head lamp" not in lx.part_forms("head_light_left")  # shared with the motorbike's value ...
    assert "left head lamp" in lx.part_forms_for_category("head_light_left", "car")  # ... so the owner decides
    assert "coach" in lx.shape_forms("bus") and "estate car" in lx.shape_forms("wagon")
    assert {"boot", "kickstand", "coach", "entity"} <= lx.lexicon_words()
