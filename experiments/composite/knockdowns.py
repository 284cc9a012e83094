"""The knock-down trials of `mjxmimic play COMPOSITE --knockdowns N --force 1000 --seed S`, one
after another on the CPU, each traced step by step: the loop that gate_trace.py and
knockdown_states.py share (outcomes.py runs its trials longer)."""
from collections.abc import Callable, Iterator
from typing import Any

from mjxmimic.portable import composite as C
from mjxmimic.task import recovery as protocol


def traced(player: C.Player, seed: int, count: int, record: Callable[[Any], Any]) -> Iterator[tuple[int, Any, list]]:
    """(trial index, final rule state, record(decision) of every step) of the first `count` trials
    that knocked the character down."""
    first = player.composite.start_expert(None)
    n = protocol.steps(player.env.control_dt)
    i = done = 0
    while done < count:
        tr = protocol.draw_trials(seed, i, 1, float(player.env.clip_durations[first]), "random", n.total)
        rows: list = []
        st, _ = C.recovery_trial(player, float(tr.start_time[0]), first, 1000.0, float(tr.turn[0]), tr.u[0], n,
                                 lambda k, d: rows.append(record(d)))
        i += 1
        if st.down_step >= 0:
            done += 1
            yield i - 1, st, rows
