"""samplehd.export: other formats written from a finished dataset, which they only read.

- :mod:`samplehd.export.lerobot`: LeRobot v3.0 (``meta/``, ``data/``, ``videos/``), ``samplehd export lerobot``;
- :mod:`samplehd.export.sample_hd`: SAMPLE-HD's own layout, in its Unity frame
  (:mod:`samplehd.export.unity_frame`), ``samplehd export sample-hd``;
- :mod:`samplehd.export.rerun_recording`: one episode as a Rerun recording, ``samplehd export rerun``;
- :mod:`samplehd.export.mjcf`: a scene as MJCF for MuJoCo's viewer, ``samplehd export-mjcf``;
- :mod:`samplehd.export.staging`: where an export is written before it is moved into place.

A floor beside :mod:`samplehd.envs`: it reads datasets through :mod:`samplehd.dataset` and nothing below
imports it.
"""
