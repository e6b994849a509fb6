"""The generic reference path: Pyro's own variable elimination (``TraceEnum_ELBO.compute_marginals``) on the same
factor graph the exact engine contracts.

The program is first run on an :class:`EnumWorld`, which yields the factor graph: the posterior tables of the latent
sites it reads, the constraint factors of its pivots and copies, its "some part" flags and its counts. Here that
graph is written as an ordinary Pyro model - global guesses as enumerated sites, then ``pyro.markov`` over objects with each
object's latents, a ``pyro.plate`` over part slots, the factors as ``pyro.factor`` and counts as running-state
sites - and handed to ``TraceEnum_ELBO``. It is exact and general but pays Pyro's per-site machinery for every
object, which is the baseline the exact engine's benchmark compares against.
"""

from __future__ import annotations

import math

import pyro
import pyro.distributions as dist
import torch
from pyro.infer import TraceEnum_ELBO, config_enumerate

from po3d_ppl.evidence import DTYPE, SceneEvidence
from po3d_ppl.reasoning.execution import run_program
from po3d_ppl.reasoning.inference.enum_world import EnumWorld
from po3d_ppl.reasoning.inference.sop import Sop
from po3d_ppl.reasoning.posterior import SitePosteriors


def _evaluate(t: torch.Tensor, env: dict[int, torch.Tensor], k: int, parts: torch.Tensor,
              keep: int | None = None) -> torch.Tensor:
    """A layout tensor at the current values: object axis = k, part axis = the part plate, others from ``env``.

    With ``keep`` (a layout position), that axis is not indexed but returned last (a Categorical's values).
    """
    if keep is not None:
        t = t.reshape([1] * (-keep - t.dim()) + list(t.shape))
    if t.dim() == 0:
        return t
    index = []
    for axis in range(-t.dim(), 0):
        if axis == keep:
            continue
        if t.shape[axis] == 1:
            index.append(0)
        elif axis == -2:
            index.append(k)
        elif axis == -1:
            index.append(parts)
        else:
            index.append(env[axis])
    if keep is None:
        return t[tuple(index)]
    return t.movedim(keep, 0)[(slice(None), *index)].movedim(0, -1)


def _sop_value(sop: Sop | None, env, k, parts) -> torch.Tensor:
    if sop is None:
        return torch.ones((), dtype=DTYPE)
    total = torch.zeros((), dtype=DTYPE)
    for coef, factors in sop.terms:
        term = torch.full((), coef, dtype=DTYPE)
        for f in factors:
            term = term * _evaluate(f, env, k, parts).to(DTYPE)
        total = total + term
    return total


def _log(value: torch.Tensor) -> torch.Tensor:
    return torch.log(value.clamp(min=0.0))


def _guess(name: str, size: int) -> torch.Tensor:
    """An enumerated site without a prior of its own (a pivot, witness or running count): uniform, with its
    ``1/size`` compensated so that only its constraint factors weigh its values."""
    value = pyro.sample(name, dist.Categorical(logits=torch.zeros(size, dtype=DTYPE)))
    pyro.factor(f"{name}_scale", torch.tensor(math.log(size), dtype=DTYPE))
    return value


def generic_distribution(typed, posteriors: SitePosteriors, evidence: SceneEvidence,
                         num_values: int, semantics: str = "intended") -> tuple[torch.Tensor, float]:
    world = EnumWorld(posteriors, evidence)
    answer = run_program(typed, world, semantics)
    n, p = world.num_objects, world.num_parts
    globals_ = [d for d in world.dims if d.kind == "global"]
    flags = {a.dim: a.members for a in world.part_aggregates}
    locals_ = [d for d in world.dims if d.kind == "local" and d not in flags]
    part_dims = [d for d in world.dims if d.kind == "part"]
    parts = torch.arange(p)

    def model():
        env: dict[int, torch.Tensor] = {}
        for d in globals_:  # guesses: compensated so the model's total mass is the valid mass
            if d.size == 1:  # nothing to enumerate (Pyro cannot pack a size-1 enumeration dim)
                env[d.pos] = torch.tensor(0)
                continue
            env[d.pos] = _guess(d.name, d.size)
        states = {agg.dim.pos: torch.tensor(0) for agg in world.aggregates}
        for k in pyro.markov(range(n)):
            for d in locals_:
                if d.size == 1:
                    env[d.pos] = torch.tensor(0)
                    if d in world.q:  # keep the (certain) posterior's mass
                        pyro.factor(f"{d.name}_{k}", torch.log(_evaluate(world.q[d], env, k, parts)))
                elif d in world.q:
                    env[d.pos] = pyro.sample(f"{d.name}_{k}", dist.Categorical(
                        probs=_evaluate(world.q[d], env, k, parts, keep=d.pos)))
                else:  # a witness: no prior, its constraint factor selects its value
                    env[d.pos] = _guess(f"{d.name}_{k}", d.size)
            witnesses = {}
            for a, flag in enumerate(flags):  # "some part is a member": its first member part, or none (= p)
                witnesses[flag] = _guess(f"witness{a}_{k}", p + 1)
                env[flag.pos] = (witnesses[flag] != p).long()
            at = {d.pos: (env[d.pos] == k) for d in world.pivot_dims}
            with pyro.plate(f"parts_{k}", p, dim=-1):
                for d in part_dims:
                    if d.size == 1:
                        env[d.pos] = torch.tensor(0)
                        pyro.factor(f"{d.name}_{k}", torch.log(_evaluate(world.q[d], env, k, parts)))
                        continue
                    env[d.pos] = pyro.sample(f"{d.name}_{k}", dist.Categorical(
                        probs=_evaluate(world.q[d], env, k, parts, keep=d.pos)))
                for a, (flag, members) in enumerate(flags.items()):
                    w, member = witnesses[flag], _sop_value(members, env, k, parts)
                    first = torch.where(parts < w, 1 - member, torch.where(parts == w, member, 1.0))
                    pyro.factor(f"witness{a}_{k}_parts", _log(first))
                for i, f in enumerate(world.factors):
                    if f.slot is None and not _part_level(f):
                        continue
                    value = _factor_value(f, env, k, parts, at)
                    pyro.factor(f"factor{i}_{k}", _log(value))
            for i, f in enumerate(world.factors):
                if f.slot is None and not _part_level(f):
                    pyro.factor(f"factor{i}_{k}", _log(_factor_value(f, env, k, parts, at)))
            for a, agg in enumerate(world.aggregates):
                member = _sop_value(agg.members, env, k, parts)
                prev = states[agg.dim.pos]
                state = _guess(f"count{a}_{k}", agg.dim.size)
                target = torch.where(member > 0.5, (prev + 1).clamp(max=agg.cap), prev)
                pyro.factor(f"count{a}_{k}_step", _log((state == target).to(DTYPE)))
                states[agg.dim.pos] = state
            if k == n - 1:  # the answer reads the final counts, so it lives in the chain's last step
                env.update(states)
                value = _evaluate(answer, env, 0, parts).long()
                outcome = torch.where(value >= 0, value, num_values)  # extra last category: invalid value
                pyro.sample("answer", dist.Categorical(logits=_log(torch.nn.functional.one_hot(
                    outcome, num_values + 1).to(DTYPE))))

    def guide():
        pass

    model = config_enumerate(model, default="parallel")
    elbo = TraceEnum_ELBO(max_plate_nesting=1)
    mass = math.exp(-elbo.loss(model, guide))  # probability that every unique found one member
    if mass == 0.0:
        return torch.zeros(num_values, dtype=DTYPE), 1.0
    marginal = elbo.compute_marginals(model, guide)["answer"]
    probs = marginal.probs.reshape(-1, num_values + 1)[0].to(DTYPE)[:num_values] * mass
    return probs, float(max(0.0, 1.0 - probs.sum()))


def _part_level(f) -> bool:
    return any(t.dim() >= 1 and t.shape[-1] > 1 for sop in (f.on, f.off, f.at_slot) if sop is not None
               for _, fs in sop.terms for t in fs)


def _factor_value(f, env, k, parts, at) -> torch.Tensor:
    if f.owner is None:
        return _sop_value(f.on, env, k, parts)
    on = _sop_value(f.on, env, k, parts)
    if f.slot is not None:
        on = torch.where(parts == env[f.slot.pos], _sop_value(f.at_slot, env, k, parts), on)
    return torch.where(at[f.owner.pos], on, _sop_value(f.off, env, k, parts))
