"""The control step (`step.py`) and where episodes start and how long evaluations run
(`starts.py`), written once over a physics backend, and the two environments that run them: the
vmapped MJX env for training (`mjx_env.py`) and MuJoCo C for CPU playback (`cpu_env.py`)."""
