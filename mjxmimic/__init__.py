"""mjxmimic: DeepMimic-style motion imitation on MuJoCo MJX, trained with Brax PPO."""

__version__ = "0.1.0"
