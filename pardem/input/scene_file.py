"""Scene files: ``load_scene`` reads and validates a TOML scene (errors prefixed with the
file's path), ``scene_to_toml`` / ``write_scene`` write one back with every key (the resolved
scene stored with a run; ``load_scene`` of it gives an equal ``Scene.to_dict()``).

Stage: input.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from .scene import Scene, SceneError
from .schema import scene_from_dict


def load_scene(path: str | Path) -> Scene:
    """Read and validate a TOML scene file; errors are prefixed with the file path."""
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"{p}: no such scene file")
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise SceneError(f"{p}: malformed TOML: {e}") from None
    try:
        return scene_from_dict(raw, base_dir=p.parent, source=str(p))
    except SceneError as e:
        raise SceneError(f"{p}: {e}") from None


# ---------------------------------------------------------------- TOML output

def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # shortest repr round-trips exactly; inf/nan are refused on input
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    chars = []
    for ch in str(v):
        if ch in '"\\':
            chars.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            chars.append(f"\\u{ord(ch):04x}")
        else:
            chars.append(ch)
    return '"' + "".join(chars) + '"'


def scene_to_toml(scene: Scene) -> str:
    """The scene as TOML text with every key written; ``load_scene`` of it gives an equal
    ``to_dict()``."""
    out = [f"# pardem scene (SI units: m, kg, s, rad); kind = {scene.info.kind}"]
    for name, body in scene.to_dict().items():
        rows = body if isinstance(body, list) else [body]
        head = f"[[{name}]]" if isinstance(body, list) else f"[{name}]"
        for row in rows:
            tables = {k: v for k, v in row.items() if isinstance(v, list) and v
                      and isinstance(v[0], dict)}  # [[contact.pair]]
            out += ["", head] + [f"{k} = {_toml_value(v)}" for k, v in row.items()
                                 if k not in tables]
            for key, sub in tables.items():
                for t in sub:
                    out += ["", f"[[{name}.{key}]]"] + [f"{k} = {_toml_value(v)}"
                                                        for k, v in t.items()]
    return "\n".join(out) + "\n"


def write_scene(scene: Scene, path: str | Path) -> None:
    """Write ``scene_to_toml(scene)`` atomically (temporary file, then ``os.replace``)."""
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(scene_to_toml(scene), encoding="utf-8")
    os.replace(tmp, p)
