"""States of knocked-down bodies, for getups to train from (`env.start_states`): the first N
knock-downs of a composite's recovery trials (`mjxmimic play COMPOSITE --knockdowns N --force 1000
--seed S`'s trials, on MuJoCo C), every third control step from the knock-down until the body is up
again (root above 0.8 of standing height) or the trial ends, as qpos and qvel of the character.

    python experiments/composite/knockdown_states.py COMPOSITE.npz SEED N OUT.npz
"""
import sys
from pathlib import Path

import numpy as np

from knockdowns import traced
from mjxmimic.portable import composite as C
from mjxmimic.task import recovery as protocol

path, seed, trials, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
player = C.Player(C.read(Path(path)))
nq, nv = player.env.physics.scene.nq, player.env.physics.scene.nv
up = protocol.UP_FRACTION * player.gate.stand_height
qpos, qvel = [], []
last = -1
for last, st, rows in traced(player, seed, trials,
                             lambda d: (player.env.data.qpos[:nq].copy(), player.env.data.qvel[:nv].copy(),
                                        float(d.root_height))):
    for q, v, h in rows[st.down_step::3]:
        if h >= up:
            break
        qpos.append(q)
        qvel.append(v)
np.savez(out, qpos=np.array(qpos, np.float32), qvel=np.array(qvel, np.float32))
print(f"{len(qpos)} states from {trials} knock-downs ({last + 1} trials) -> {out}")
