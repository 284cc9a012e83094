"""Why knock-downs fail to recover: the first N knock-down trials of a composite (`mjxmimic play
COMPOSITE --knockdowns N --force 1000 --seed S`'s trials), run on for up to 12 s after the
knock-down instead of 5 s. One JSON line per trial: seconds from the knock-down to the first time
up again (root at 0.8 of standing height), whether it went down again after that, when the
recovery rule would have held without the 5 s limit, and the expert chosen every third step
(W walk, D face-down getup, U face-up getup); then the counts.

    python experiments/composite/outcomes.py COMPOSITE.npz SEED N > outcomes.jsonl
"""
import json
import sys
from pathlib import Path

import numpy as np

from mjxmimic.portable import composite as C
from mjxmimic.task import recovery as protocol

path, seed, trials = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
c = C.read(Path(path))
player = C.Player(c)
first = c.start_expert(None)
dt = player.env.control_dt
n = protocol.steps(dt)
long = n._replace(recover=round(12 / dt), total=n.lead + n.down_within + round(12 / dt))
dur = float(player.env.clip_durations[first])
stand = player.gate.stand_height
out = []
i = 0
while len(out) < trials:
    tr = protocol.draw_trials(seed, i, 1, dur, "random", n.total)
    u = np.concatenate([tr.u[0], np.random.default_rng(1000 + i).random(long.total)])
    rows = []
    st, _ = C.recovery_trial(player, float(tr.start_time[0]), first, 1000.0, float(tr.turn[0]), u, long,
                             lambda k, d: rows.append((int(d.choice), float(d.root_height), float(d.pose_error))))
    i += 1
    down = int(st.down_step)
    if down < 0:
        continue
    h = np.array([r[1] for r in rows])
    up, low = h >= protocol.UP_FRACTION * stand, h < protocol.DOWN_FRACTION * stand
    first_up = next((k for k in range(down + 1, len(rows)) if up[k]), -1)
    rec = int(st.recovered_step)
    out.append({"trial": i - 1, "down_s": down * dt, "first_up_s": (first_up - down) * dt if first_up >= 0 else None,
                "refall": first_up >= 0 and bool(np.any(low[first_up:])),
                "recovered_s": (rec - down) * dt if rec >= 0 else None,
                "choices": "".join("WDU"[r[0]] for r in rows[down::3]),
                "err_at_end": rows[-1][2], "h_end": rows[-1][1]})
    print(json.dumps(out[-1]), flush=True)
r = [o["recovered_s"] for o in out]
print("within 5 s", sum(x is not None and x <= 5 for x in r), "within 12 s", sum(x is not None for x in r),
      "never up", sum(o["first_up_s"] is None for o in out), "refall", sum(o["refall"] for o in out), "of", len(out))
