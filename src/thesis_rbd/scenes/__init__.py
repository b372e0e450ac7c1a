"""Built-in scenes: TOML files shipped inside the package, looked up by name.

>>> import thesis_rbd as rbd
>>> "dzhanibekov" in rbd.scenes.names()
True
>>> world = rbd.scenes.get("dzhanibekov").build()

Each ``<name>.toml`` beside this module is a scene file in the format of
:mod:`thesis_rbd.scene`; they are package data, so a non-editable install has them too.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from thesis_rbd.scene import Scene, SceneError, load_scene, parse_scene, urdf_scene

__all__ = ["DEFAULT", "get", "is_builtin", "names", "resolve"]

DEFAULT = "dzhanibekov"
"""The scene ``thesis-rbd run`` runs when given none."""


def _files() -> dict[str, resources.abc.Traversable]:
    folder = resources.files(__name__)
    return {
        entry.name.removesuffix(".toml"): entry
        for entry in folder.iterdir()
        if entry.is_file() and entry.name.endswith(".toml")
    }


def _source(name: str) -> str:
    return f"built-in scene {name!r}"


def is_builtin(scene: Scene) -> bool:
    """Whether ``scene`` is a built-in scene (or one of its ``with_world`` copies), not a
    file that happens to share a built-in's name."""
    return scene.name in _files() and scene.source == _source(scene.name)


def names() -> list[str]:
    """Names of the built-in scenes, sorted."""
    return sorted(_files())


def get(name: str) -> Scene:
    """Load a built-in scene by name.

    Parameters
    ----------
    name : str
        One of :func:`names`.

    Raises
    ------
    SceneError
        If there is no built-in scene of that name.
    """
    files = _files()
    if name not in files:
        raise SceneError(f"no built-in scene {name!r}; built-ins: {', '.join(sorted(files))}")
    entry = files[name]
    with resources.as_file(entry) as path:
        return parse_scene(
            entry.read_text(encoding="utf-8"),
            name=name,
            source=_source(name),
            folder=Path(path).parent,
        )


def resolve(argument: str) -> Scene:
    """The scene a command line names: a scene file (.toml), a URDF file (that model alone,
    its base held), or a built-in scene's name.

    Raises
    ------
    SceneError
        If ``argument`` is none of them, or the file it names is at fault.
    """
    path = Path(argument)
    if path.suffix.lower() == ".urdf":
        return urdf_scene(path)
    if path.is_file() or path.suffix == ".toml" or "/" in argument or "\\" in argument:
        return load_scene(path)
    if argument in names():
        return get(argument)
    raise SceneError(
        f"no scene file or built-in scene named {argument!r}; built-ins: {', '.join(names())}"
    )
