"""Studies: many cases through the Snakemake pipeline, and what is made of them.

Modules: :mod:`~ced.study.cases` (the case table of a config and its chunks),
:mod:`~ced.study.config` (study config: schema, checks, size and memory estimates),
:mod:`~ced.study.chunk_job` (the job that simulates one chunk), :mod:`~ced.study.maps`
(chunks → per-family summaries and grid maps), :mod:`~ced.study.safe_speed` (safe speed
limits), :mod:`~ced.study.figures` (overview, Campbell, resonance and worst-case figures),
:mod:`~ced.study.convergence` and :mod:`~ced.study.convergence_figures` (what accuracy
costs in time), :mod:`~ced.study.fidelity_ladder` (one scene through every model).

Nothing here imports Snakemake; the workflow's scripts call these functions.

Imports: :mod:`ced.io`, :mod:`ced.simulation.simulate` and everything below them.
"""
