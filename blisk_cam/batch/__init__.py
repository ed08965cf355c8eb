"""Batch runs on a Dask cluster (``python -m blisk_cam batch JOBS.toml``): jobs from a TOML
file, each one of the single commands, a per-blade run of a whole-blisk scan or a sweep over
set-ups, run on a local cluster or a scheduler's workers. The only package that imports dask
(an optional dependency: ``pip install blisk-cam[batch]``); a front end like ``cli``, never
imported by the core or the Blender side."""
