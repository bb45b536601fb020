"""The optimiser: configuration, the evaluation of one blade, campaigns, and the ``millfoil`` command line.

Uses :mod:`geometry`, :mod:`meshing` and :mod:`solver` (never the other way round). Modules:

* :mod:`optimizer.config` — configuration files read once into frozen, validated objects (``Config``;
  ``load_config(path, overrides, *, schema=Config)``: a schema with more sections loads the same way);
* :mod:`optimizer.pipeline` — ``evaluate(config)``: geometry → mesh → solve → figures for one blade,
  never raising for a bad one; each stage a function of its own;
* :mod:`optimizer.figures` — figures of merit of a solved blade and its wall distributions;
* :mod:`optimizer.evaluation` — the records (``Evaluation``, ``WallDistribution``, ``Artifacts``) and
  their strict JSON;
* :mod:`optimizer.saving` — ``save(evaluation, config, directory)``: the files of one evaluation;
* :mod:`optimizer.campaign` — optimisation campaigns over ``pipeline.evaluate`` (problem, driver, runner,
  store);
* :mod:`optimizer.cli` — ``millfoil``, one module per command group.
"""
