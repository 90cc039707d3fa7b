"""The seed's workloads' spec, re-exported by :mod:`.spec` with every other spec."""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, ClassVar

from ...common import UserError
from ...common.renamed import takes_old_seed
from ..fields import DTYPES, MAX_RAYS, check_choice, check_int, file_sha256
from .scene import BUILTIN_SCENES, builtin_scene_path, read_scene

__all__ = ["RAY_KINDS", "SEED_VERSION", "SeedSpec"]

SEED_VERSION = 2  # 2: the sample is runs of consecutive rays (workload.sample_runs)
RAY_KINDS = ("primary", "reflected", "shadow")
_MAX_SIDE = 4096  # a 4096 x 4096 trace is about 4 GB of ray records


@takes_old_seed
@dataclass(frozen=True)
class SeedSpec:
    """A sample of one kind of ray from the seed's render of a scene (:mod:`tribench.workloads.seed.workload`).

    ``scene``: a built-in scene or a scene file, stored absolute (refused here if it does not parse).
    ``sample``: the rays drawn from the ``width`` x ``height`` render (all if fewer). ``dtype``: the seed's
    ``Vecteur`` holds float, so float32 is the faithful replay."""

    scene: str = "scene02"
    rays: str = "primary"
    sample: int = 4096
    width: int = 512
    height: int = 512
    dtype: str = "float32"
    rng_seed: int = 0

    kind: ClassVar[str] = "seed"
    version: ClassVar[int] = SEED_VERSION

    def __post_init__(self) -> None:
        put = object.__setattr__  # frozen: normalise the fields once, here
        if isinstance(self.scene, os.PathLike):
            put(self, "scene", os.fspath(self.scene))
        if not isinstance(self.scene, str) or not self.scene:
            raise UserError(f"scene must be a built-in scene name or a file path, got {self.scene!r}")
        if self.scene not in BUILTIN_SCENES:
            path = Path(self.scene).expanduser()
            if not path.exists():
                raise UserError(
                    f"unknown scene {self.scene!r}: not one of {', '.join(BUILTIN_SCENES)} and no such file"
                )
            read_scene(path)  # SceneError names a folder, an unreadable file or the bad line
            put(self, "scene", str(path.resolve()))
        check_choice("rays", self.rays, RAY_KINDS)
        put(self, "sample", check_int("sample", self.sample, 1, MAX_RAYS))
        put(self, "width", check_int("width", self.width, 1, _MAX_SIDE))
        put(self, "height", check_int("height", self.height, 1, _MAX_SIDE))
        check_choice("dtype", self.dtype, DTYPES)
        put(self, "rng_seed", check_int("rng_seed", self.rng_seed, 0, 2**63 - 1))

    @property
    def mode(self) -> str:
        """``"any"`` for shadow rays (stop at the first occluder), else ``"closest"``."""
        return "any" if self.rays == "shadow" else "closest"

    @property
    def is_file(self) -> bool:
        return self.scene not in BUILTIN_SCENES

    @property
    def scene_path(self) -> Path:
        return Path(self.scene) if self.is_file else builtin_scene_path(self.scene)

    @property
    def scene_label(self) -> str:
        """Short name for tables: the built-in name or the file's stem."""
        return Path(self.scene).stem if self.is_file else self.scene

    def scene_identity(self) -> dict[str, Any]:
        """What names the scene in a workload id: its text's sha256, not its path."""
        return {"scene": "file" if self.is_file else self.scene, "scene_sha256": file_sha256(str(self.scene_path))}

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **asdict(self)}

    def targets(self) -> dict[str, Any]:
        return {"sample_rays": self.sample}

    def summary(self) -> str:
        return (
            f"seed {self.scene_label} {self.rays} sample={self.sample} of {self.width}x{self.height} "
            f"{self.dtype} rng_seed={self.rng_seed}"
        )
