"""The control step (`step.py`), written once over a physics backend, and the two environments
that run it: the vmapped MJX env for training (`mjx_env.py`) and MuJoCo C for CPU playback
(`cpu_env.py`)."""
