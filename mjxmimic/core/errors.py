"""The one exception type that the command line turns into a one-line error, and a JSON reader
that raises it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


class UserError(Exception):
    """Bad input from a person (a file, a config key, a run folder): the message names it."""


def read_json(path: Path, what: str) -> Any:
    """A JSON file's contents; a file that cannot be read or parsed is a UserError naming it as `what`."""
    try:
        return json.loads(Path(path).read_text())
    except OSError as err:
        raise UserError(f"{path}: cannot read the {what} ({err.strerror})") from None
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: the {what} is not JSON ({err.msg}, line {err.lineno})") from None
