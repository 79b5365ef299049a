"""A small TOML writer for shot files (Blender's Python has tomllib to read, nothing to write).

Values: str, bool, int, float, lists of those, and dicts written as inline tables inside
lists or as `[section]` / `[[array]]` tables at the top level.
"""
import math

import numpy as np


def _key(k):
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return _string(k)


def _string(s):
    out = ['"']
    for ch in s:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append("\\u%04x" % ord(ch))
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _float(x):
    """The shortest text that reads back as the same float32: Blender's values are float32,
    so 0.8 is written, not 0.800000011920929."""
    if not math.isfinite(x):
        raise ValueError(f"cannot write a non-finite number ({x}) to a shot file")
    x32 = np.float32(x)
    if x32 == 0:
        return "0.0"
    if 1e-4 <= abs(x32) < 1e7:
        text = np.format_float_positional(x32, unique=True, trim="-")
    else:
        text = np.format_float_scientific(x32, unique=True, trim="-")
    if not any(c in text for c in ".eE"):
        text += ".0"
    return text


def value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _float(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {value(x)}" for k, x in v.items()) + " }" if v else "{}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(value(x) for x in v) + "]"
    # mathutils vectors and other sequences
    if hasattr(v, "__len__") and hasattr(v, "__getitem__"):
        return value([float(x) for x in v])
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _table_body(d, lines):
    for k, v in d.items():
        if v is None:
            continue
        lines.append(f"{_key(k)} = {value(v)}")


def _table(header, name, d, subtables, lines):
    """A table (or array-of-tables entry) `d` under `header`, with the keys named in
    `subtables` written after it as [name.key] tables."""
    lines.append(header)
    _table_body({sk: sv for sk, sv in d.items() if sk not in subtables}, lines)
    lines.append("")
    for sk in subtables:
        lines.append(f"[{name}.{_key(sk)}]")
        _table_body(d[sk], lines)
        lines.append("")


def dumps(doc, header=None):
    """doc: {section: dict | list[dict]}; scalar top-level keys are written first."""
    lines = []
    if header:
        lines.extend("# " + line if line else "#" for line in header.splitlines())
        lines.append("")
    scalars = {k: v for k, v in doc.items() if not isinstance(v, (dict, list)) or
               (isinstance(v, list) and not all(isinstance(x, dict) for x in v)) or v == []}
    _table_body({k: v for k, v in scalars.items() if v != []}, lines)
    for k, v in doc.items():
        if k in scalars:
            continue
        if isinstance(v, dict):
            sub = [sk for sk, sv in v.items() if isinstance(sv, dict) and sv]
            _table(f"[{_key(k)}]", _key(k), v, sub, lines)
        else:
            for item in v:
                # Only params becomes a [swarm.params] table; other dicts stay inline.
                sub = [sk for sk, sv in item.items() if isinstance(sv, dict) and sk == "params" and sv]
                _table(f"[[{_key(k)}]]", _key(k), item, sub, lines)
    return "\n".join(lines).rstrip() + "\n"
