"""Reference implementations of exact inference, for tests and benchmarks only (``SceneReasoner.reference``).

- ``dense``: every joint assignment of the latents a program reads, as one batch; exponential, for small scenes
  and cross-checks of the exact engine;
- ``generic``: Pyro's own variable elimination (``TraceEnum_ELBO.compute_marginals``) on the exact engine's factor
  graph; slow, the baseline of the inference benchmark.

Neither is a public inference method: use ``exact``, ``sampling`` or ``auto``.
"""

REFERENCE_METHODS = ("dense", "generic")
