"""Many scenes: tables, sweeps, progress, resume, failure isolation, local processes or Dask.

Public objects
--------------
:func:`load_batch`
    Read the scenes of a batch from a CSV table (a header of scene fields plus a
    ``name`` column giving each output's file stem) or a TOML file (``[base]``
    fields, ``[[scene]]`` entries and/or a ``[sweep]`` of parameter values).
:func:`expand_sweep`
    Cartesian product of parameter lists and ranges (e.g. every hour of a year).
:func:`run_batch`
    Render every scene to ``DIR/<name>.exr``: complete outputs are skipped
    (resume), partial ones redone, a failing scene is reported without losing
    the others, and a summary is returned and written to
    ``DIR/batch_summary.json``.  Runs in this process, in ``workers`` local
    processes, or on a Dask distributed cluster (``client=`` or
    ``scheduler=`` address; optional extra ``atmoscatter[dask]``).
:class:`BatchResult`, :class:`BatchSummary`
:func:`weather_batch`, :func:`read_epw`, :func:`write_weather_table`, :class:`WeatherBatch`, :class:`WeatherSite`
    One Perez all-weather scene per daylit hour of an EnergyPlus weather file, for
    :func:`run_batch` (:mod:`~atmoscatter.batch.weather`; optional extra
    ``atmoscatter[weather]``).

Modules, in the order a batch runs: :mod:`~atmoscatter.batch.tables` (reading),
:mod:`~atmoscatter.batch.job` (one scene: fingerprint, up-to-date check, render),
:mod:`~atmoscatter.batch.run` (processes, Dask, signals, progress) and
:mod:`~atmoscatter.batch.results` (what comes back); :mod:`~atmoscatter.batch.weather` turns a
weather file into scenes.
"""

from .job import FINGERPRINT_KEY as FINGERPRINT_KEY
from .job import scene_fingerprint
from .results import BatchInterrupted, BatchResult, BatchSummary
from .run import run_batch
from .tables import expand_sweep, load_batch
from .weather import WeatherBatch, WeatherSite, read_epw, weather_batch, write_weather_table

__all__ = ["load_batch", "expand_sweep", "run_batch", "BatchResult", "BatchSummary",
           "BatchInterrupted", "scene_fingerprint", "weather_batch", "read_epw",
           "write_weather_table", "WeatherBatch", "WeatherSite"]
