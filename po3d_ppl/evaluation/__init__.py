"""Evaluation: accuracy tables against the baselines, difficulty analysis and calibration studies.

It may use every stage (it measures them against each other); no stage imports it.

- :mod:`~po3d_ppl.evaluation.backends`: the evidence back-end interface (the simulated sensor today);
- :mod:`~po3d_ppl.evaluation.cache`: evidence cached per image hash and back-end identity (safetensors);
- :mod:`~po3d_ppl.evaluation.runner`: every method on one evidence per image -> question records;
- :mod:`~po3d_ppl.evaluation.metrics`: the paper's Table 1 columns, CLEVR core, per family;
- :mod:`~po3d_ppl.evaluation.calibration`: ECE, MCE, Brier, NLL, classwise ECE, reliability bins (torchmetrics);
- :mod:`~po3d_ppl.evaluation.difficulty`: accuracy against occlusion ratio and part size (paper section 5.4);
- :mod:`~po3d_ppl.evaluation.plots`, :mod:`~po3d_ppl.evaluation.report`: PNGs, Markdown and JSON, the noise sweep.
"""
