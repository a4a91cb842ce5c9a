"""The device's data files, from the package or from a user's device folder.

A device folder (``exoleg simulate --walk --device DIR``) may hold any of
:data:`FILES` and an ``actuators/`` folder with ``hip.toml``, ``knee.toml``,
``ankle.toml``; what it does not hold comes from the package's ``data/device``. Every
file is read with :func:`exoleg.io.read_text` and validated by its loader, so a bad file
is one error naming the file, the field and what is allowed.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from exoleg.errors import ParameterError
from exoleg.io import read_text

FILES = ("safety.toml", "walking.toml", "sensors.toml", "gait_phase.toml",
         "walking_control.toml", "transparency.toml", "assist.toml")
ACTUATOR_FILES = ("hip.toml", "knee.toml", "ankle.toml")
#: What else the package's ``data/device`` holds, which a copy of it brings along: not
#: device files, and what to do with each instead
SHIPPED_EXTRAS = {
    "hip-variants": "the shipped hip motor's variants, not a device file: copy the one "
                    "wanted to actuators/hip.toml and remove this folder",
    "canopen": "the simulated drives' object dictionary, not a device file: remove this "
               "folder"}


def check_folder(folder: str | Path) -> Path:
    """A device folder: it exists, and holds nothing but the device's files."""
    p = Path(folder)
    if not p.is_dir():
        raise ParameterError(str(p), "(device folder)", "is not a folder")
    allowed = set(FILES) | {"actuators"}
    for f in p.iterdir():
        if f.name not in allowed and not f.name.startswith("."):
            raise ParameterError(str(p), f.name, SHIPPED_EXTRAS.get(f.name, "unknown device file")
                                 + " (a device folder holds only the files it replaces: "
                                 + ", ".join(sorted(allowed)) + ")")
    act = p / "actuators"
    if act.exists():
        for f in act.iterdir():
            if f.name not in ACTUATOR_FILES and not f.name.startswith("."):
                raise ParameterError(str(act), f.name, "unknown actuator file (allowed: "
                                     + ", ".join(ACTUATOR_FILES) + ")")
    return p


def load(name: str, folder: str | Path | None = None) -> tuple[str, dict[str, Any]]:
    """(where, parsed TOML) of device file ``name`` (e.g. ``"sensors.toml"`` or
    ``"actuators/hip.toml"``): the folder's when it has one, else the package's. A
    folder that is not a device folder is refused (:func:`check_folder`), whichever of
    its files is asked."""
    if folder is not None:
        check_folder(folder)
    if folder is not None and (Path(folder) / name).exists():
        path = Path(folder) / name
        where, text = str(path), read_text(path, f"device file {name} (TOML)")
    else:
        where = f"exoleg/data/device/{name}"
        text = resources.files("exoleg").joinpath("data", "device", *name.split("/")).read_text()
    try:
        return where, tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(where, "(syntax)", f"not valid TOML: {e}") from None
