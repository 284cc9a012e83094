"""Where the face-down getup goes wrong in a composite's knock-down trials: the first N
knock-downs of `mjxmimic play COMPOSITE --knockdowns N --force 1000 --seed S` traced step by step
(each expert's value and candidate time, the root's height, whether the chest faces down or up),
then, for expert E (default 1, the second expert composed): the root height when its clip ran out
and whether the gate chose it again within 0.4 s, and its entry times and root heights on entry.

    python experiments/composite/gate_trace.py COMPOSITE.npz SEED N [E] > trace.txt
"""
import sys
from pathlib import Path

import numpy as np

from mjxmimic.core import quat
from mjxmimic.portable import composite as C
from mjxmimic.task import recovery as protocol

path, seed, trials = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
expert = int(sys.argv[4]) if len(sys.argv) > 4 else 1
c = C.read(Path(path))
player = C.Player(c)
dt = player.env.control_dt
duration = float(player.env.clip_durations[expert])
ends, again, entries, failed = [], 0, [], 0


def traced(seed: int, count: int, record):
    """(trial index, final rule state, record(decision) of every step) of the first `count` trials
    that knocked the character down, one after another as `play --knockdowns` runs them."""
    first = player.composite.start_expert(None)
    n = protocol.steps(dt)
    i = done = 0
    while done < count:
        tr = protocol.draw_trials(seed, i, 1, float(player.env.clip_durations[first]), "random", n.total)
        rows = []
        st, _ = C.recovery_trial(player, float(tr.start_time[0]), first, 1000.0, float(tr.turn[0]), tr.u[0], n,
                                 lambda k, d: rows.append(record(d)))
        i += 1
        if st.down_step >= 0:
            done += 1
            yield i - 1, st, rows


def record(d):
    forward = quat.rotate(player.env.data.qpos[3:7], np.array([1.0, 0.0, 0.0]), np)
    return int(d.choice), float(d.root_height), float(d.times[expert]), forward[2]


for trial, st, rows in traced(seed, trials, record):
    choice = np.array([r[0] for r in rows])
    for k in range(st.down_step, len(rows)):
        if choice[k] == expert and (k == 0 or choice[k - 1] != expert):
            entries.append((rows[k][2], rows[k][1]))
        if choice[k] == expert and rows[k][2] >= duration - dt - 1e-6 and k + 1 < len(rows) and choice[k + 1] != expert:
            ends.append(rows[k][1])
            again += int(np.any(choice[k + 1:k + 1 + round(0.4 / dt)] == expert))
    ok = st.recovered_step >= 0
    failed += not ok
    print(f"trial {trial}: {'recovered' if ok else 'FAILED'}; experts every third step from the knock-down "
          f"{''.join(str(x) for x in choice[st.down_step::3])}; chest {'down' if rows[st.down_step][3] < 0 else 'up'}")
e = np.array(entries)
print(f"{failed} of {trials} failed; expert {c.names[expert]}: clip ran out {len(ends)} times, root height then "
      f"(10/50/90 %) {np.round(np.percentile(ends, [10, 50, 90]), 2).tolist()}, chosen again within 0.4 s {again} times; "
      f"{len(e)} entries, time (10/50/90 %) {np.round(np.percentile(e[:, 0], [10, 50, 90]), 2).tolist()}, "
      f"root height {np.round(np.percentile(e[:, 1], [10, 50, 90]), 2).tolist()}")
