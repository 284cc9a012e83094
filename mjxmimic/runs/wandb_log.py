"""Weights & Biases tracking of a run (`--wandb PROJECT`, config `run.wandb_project`; the `wandb`
extra), beside metrics.jsonl and TensorBoard, which stay the record.

One W&B run per run folder: its id is kept in RUN/wandb.json, so a resumed run (`--resume`)
continues the same W&B run. Every metrics row goes to W&B at its sample count; each evaluation that
becomes the run's best also sends a short video of that policy on MuJoCo's CPU simulator when
headless rendering works here (`run.wandb_videos`). W&B's own settings come from its environment
variables (WANDB_ENTITY, WANDB_MODE=offline for a machine without network, WANDB_API_KEY).
"""

from __future__ import annotations

import json
import os
import secrets
import sys
from pathlib import Path
from typing import Any

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError

ID_FILE = "wandb.json"
VIDEO_SECONDS = 4.0


def _wandb():
    try:
        import wandb
    except ImportError:
        raise UserError("--wandb needs the 'wandb' package: pip install -e \".[wandb]\"") from None
    return wandb


def check_available() -> None:
    """Fail before any training, in one line, when the package is missing or W&B has no way to log
    in (no API key and no terminal to ask for one, outside WANDB_MODE=offline or disabled)."""
    wandb = _wandb()
    if os.environ.get("WANDB_MODE", "").lower() in ("offline", "disabled", "dryrun"):
        return
    try:
        wandb.login(verify=False)
    except wandb.errors.Error as err:
        raise UserError(f"W&B: {str(err).strip().splitlines()[0]} (or set WANDB_MODE=offline to keep the "
                        "W&B run on this machine)") from None


class WandbRun:
    """The W&B side of a run folder."""

    def __init__(self, run_dir: Path, config: config_lib.Config):
        self.wandb = _wandb()
        self.run_dir = Path(run_dir)
        id_path = self.run_dir / ID_FILE
        if id_path.is_file():
            run_id = json.loads(id_path.read_text())["id"]
        else:
            run_id = secrets.token_hex(6)
            id_path.write_text(json.dumps({"id": run_id, "project": config.run.wandb_project}) + "\n")
        try:
            self.run = self.wandb.init(project=config.run.wandb_project, name=self.run_dir.name, id=run_id,
                                       resume="allow", dir=str(self.run_dir), config=config_lib.to_dict(config))
        except self.wandb.errors.Error as err:  # no network, a project it may not write to, ...
            raise UserError(f"W&B: {str(err).strip().splitlines()[0]}") from None
        self.videos = config.run.wandb_videos
        self._video_note = None

    def log(self, step: int, record: dict[str, Any]) -> None:
        values = {k: v for k, v in record.items()
                  if k != "step" and isinstance(v, (int, float)) and not isinstance(v, bool)}
        self.run.log(values, step=int(step))

    def best_video(self, step: int, make_policy_file) -> Path | None:
        """Render the new best policy (`make_policy_file()` builds it) into RUN/videos/ and send it;
        None (with one note on stderr) where this machine cannot render."""
        if not self.videos:
            return None
        from mjxmimic.portable.render import render_policy, setup_gl

        out = self.run_dir / "videos" / f"best_{int(step)}.mp4"
        try:
            setup_gl()
            out.parent.mkdir(exist_ok=True)
            render_policy(make_policy_file(), out, seconds=VIDEO_SECONDS, width=320, height=240)
        except UserError as err:  # no GL library, no imageio: train on, without videos
            if self._video_note is None:
                self._video_note = str(err)
                print(f"mjxmimic train: no W&B videos: {err}", file=sys.stderr)
            return None
        self.run.log({"eval/video": self.wandb.Video(str(out), format="mp4")}, step=int(step))
        return out

    def close(self) -> None:
        self.run.finish()
