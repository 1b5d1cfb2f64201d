"""A dict as TOML text, for scenes built in Python and read by the scene reader (Python's
standard library reads TOML but does not write it). Tables become ``[name]`` sections, lists
of tables ``[[name]]`` arrays of tables, and everything else inline values."""

from __future__ import annotations

import json
import math
from typing import Any, List, Mapping


def _key(key: Any) -> str:
    if not isinstance(key, str):
        raise TypeError(f"scene keys must be strings, got {key!r}")
    bare = key and all(c.isalnum() or c in "-_" for c in key)
    return key if bare else json.dumps(key)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if hasattr(v, "tolist"):  # NumPy arrays and scalars
        return _value(v.tolist())
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if hasattr(v, "__fspath__"):
        return json.dumps(str(v.__fspath__()))
    raise TypeError(f"cannot write {type(v).__name__} {v!r} in a scene")


def _is_table_list(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(x, Mapping) for x in v)


def _table(path: List[str], table: Mapping[str, Any], out: List[str]) -> None:
    name = ".".join(_key(p) for p in path)
    plain = [(k, v) for k, v in table.items()
             if not isinstance(v, Mapping) and not _is_table_list(v)]
    if path and (plain or not table):
        out.append(f"[{name}]")
    for k, v in plain:
        out.append(f"{_key(k)} = {_value(v)}")
    for k, v in table.items():
        if isinstance(v, Mapping):
            _table(path + [k], v, out)
        elif _is_table_list(v):
            for item in v:
                out.append(f"[[{'.'.join(_key(p) for p in path + [k])}]]")
                for ik, iv in item.items():
                    out.append(f"{_key(ik)} = {_value(iv)}")


def dumps(document: Mapping[str, Any]) -> str:
    """``document`` as TOML text."""
    out: List[str] = []
    _table([], document, out)
    return "\n".join(out) + "\n"
