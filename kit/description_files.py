"""Where robot descriptions come from: URDF and xacro files, ROS packages, bags, meshes.

* :func:`read_urdf` reads a ``.urdf`` or ``.xacro`` file and returns plain URDF XML. A file is
  expanded with xacro (the PyPI ``xacro`` package, ROS's own, which runs without ROS) whenever
  it uses xacro — whatever its name says: the TurtleBot 3's namespaced files and Nav2's
  ``sam_bot`` are xacro named ``.urdf``. Arguments (``$(arg name)``) come from ``xacro_args``.
* ``$(find pkg)`` and ``package://pkg/…`` need a ROS package's folder. Without ROS,
  :func:`package_directory` looks, in turn, in ``package_paths`` (``{"pkg": DIR}``; on the
  command line ``--package-path pkg=DIR``), the environment variable ``KIT_PACKAGE_PATH``
  (``pkg=DIR`` entries separated by ``:``), the source tree around the file (a file inside
  ``…/pkg/urdf/`` finds ``pkg``; a file in a cloned repository finds the repository's other
  packages by their ``package.xml``) and a sourced ROS environment (``AMENT_PREFIX_PATH``,
  ``ROS_PACKAGE_PATH``); a package found nowhere is an error that says how to provide it.
* :func:`read_bag_description` takes a robot's URDF from a bag's ``/robot_description``
  (``robot_state_publisher`` publishes it latched, so ``ros2 bag record -a`` keeps it) and its
  lidar's model from the bag's first ``LaserScan``.
* :func:`mesh_vertices` reads a mesh's vertices with trimesh, when it is installed.

``xacro`` and ``rosbags`` are imported only when needed: ``import kit`` stays light.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit.urdf import XACRO_NAMESPACES, RobotDescriptionError

__all__ = ["PACKAGE_PATH_VARIABLE", "is_xacro", "mesh_vertices", "package_directory",
           "parse_package_paths", "parse_xacro_args", "read_bag_description", "read_urdf",
           "resolve_uri"]

PACKAGE_PATH_VARIABLE = "KIT_PACKAGE_PATH"
"""Environment variable of ``pkg=DIR`` entries (separated by ``os.pathsep``)."""

_XACRO_USE = re.compile(r"\$\{|\$\((arg|find|env|optenv|eval|dirname|cwd)\b")
_COMMENT = re.compile(r"<!--.*?-->", re.DOTALL)


class _PackageNotFound(LookupError):
    def __init__(self, package: str) -> None:
        super().__init__(package)
        self.package = package


def is_xacro(text: str) -> bool:
    """Whether URDF text uses xacro: a ``<xacro:…>`` element or a ``${…}``/``$(…)`` outside
    comments. Declaring ``xmlns:xacro`` alone does not count (the TurtleBot 3's plain ROS 2
    files declare it and use none)."""
    body = _COMMENT.sub("", text)
    for uri in XACRO_NAMESPACES:
        match = re.search(r"xmlns:(\w+)\s*=\s*[\"']" + re.escape(uri), body)
        if match and re.search(r"<" + match.group(1) + r":", body):
            return True
    return bool(_XACRO_USE.search(body))


def parse_package_paths(items: Sequence[str]) -> dict[str, Path]:
    """``["pkg=DIR", …]`` (``--package-path`` values) as ``{"pkg": Path(DIR)}``."""
    out: dict[str, Path] = {}
    for item in items:
        name, sep, folder = item.partition("=")
        if not sep or not name.strip() or not folder.strip():
            raise ValueError(f"a package path is PACKAGE=DIR (e.g. turtlebot3_description="
                             f"~/ws/src/turtlebot3/turtlebot3_description); got {item!r}")
        out[name.strip()] = Path(folder.strip()).expanduser()
    return out


def parse_xacro_args(items: Sequence[str]) -> dict[str, str]:
    """``["name:=value", …]`` (xacro's own command-line form) as ``{"name": "value"}``."""
    out: dict[str, str] = {}
    for item in items:
        name, sep, value = item.partition(":=")
        if not sep or not name.strip():
            raise ValueError(f"a xacro argument is NAME:=VALUE (e.g. namespace:=tb3_0/); got "
                             f"{item!r}")
        out[name.strip()] = value
    return out


def _environment_paths() -> dict[str, Path]:
    text = os.environ.get(PACKAGE_PATH_VARIABLE, "")
    items = [item for item in text.split(os.pathsep) if item.strip()]
    try:
        return parse_package_paths(items)
    except ValueError as exc:
        raise RobotDescriptionError(f"{PACKAGE_PATH_VARIABLE}: {exc}") from None


def package_directory(package: str, near: Path | None = None,
                      package_paths: Mapping[str, str | Path] | None = None) -> Path:
    """The folder of ROS package ``package``, found without ROS (see the module's text).

    Raises
    ------
    LookupError
        Found nowhere (callers turn it into a message that says how to provide it).
    """
    for mapping in (package_paths or {}, _environment_paths()):
        if package in mapping:
            folder = Path(mapping[package]).expanduser()
            if not folder.is_dir():
                raise RobotDescriptionError(f"the package path given for {package!r}, "
                                            f"{folder}, is not a folder")
            return folder
    if near is not None:
        found = _package_near(package, Path(near))
        if found is not None:
            return found
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix and (Path(prefix) / "share" / package).is_dir():
            return Path(prefix) / "share" / package
    for root in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if root and (Path(root) / package).is_dir():
            return Path(root) / package
        if root and Path(root).name == package and Path(root).is_dir():
            return Path(root)
    raise _PackageNotFound(package)


_PACKAGE_NAME = re.compile(r"<name>\s*([^<\s]+)\s*</name>")


def _package_name(folder: Path) -> str | None:
    try:
        match = _PACKAGE_NAME.search((folder / "package.xml").read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError):
        return None
    return match.group(1) if match else None


def _package_near(package: str, near: Path, levels: int = 5) -> Path | None:
    """``package`` in the source tree around ``near``, as colcon would find it in a workspace:
    a folder above it named so or whose package.xml names it, else a package.xml naming it
    one or two folders below one of those five folders above (so a file in a cloned
    repository finds the repository's other packages)."""
    ancestors = list(Path(near).resolve().parents)[:levels]
    for folder in ancestors:
        if folder.name == package or _package_name(folder) == package:
            return folder
    for folder in ancestors:
        for pattern in ("*/package.xml", "*/*/package.xml"):
            for manifest in sorted(folder.glob(pattern))[:500]:
                if _package_name(manifest.parent) == package:
                    return manifest.parent
    return None


def _how_to_provide(package: str) -> str:
    return (f"the ROS package {package!r} is not found without ROS; say where its folder is "
            f"with --package-path {package}=DIR (in Python: package_paths={{{package!r}: DIR}}; "
            f"or set {PACKAGE_PATH_VARIABLE}={package}=DIR)")


def resolve_uri(uri: str, near: Path | None,
                package_paths: Mapping[str, str | Path] | None = None) -> Path:
    """The file a URDF's ``filename`` names: ``package://pkg/path`` (also Gazebo's
    ``model://``), ``file:///abs/path``, or a path relative to the URDF's folder."""
    for scheme in ("package://", "model://"):
        if uri.startswith(scheme):
            package, _, rest = uri[len(scheme):].partition("/")
            try:
                return package_directory(package, near, package_paths) / rest
            except _PackageNotFound:
                raise RobotDescriptionError(f"{uri}: {_how_to_provide(package)}") from None
    if uri.startswith("file://"):
        return Path(uri[len("file://"):])
    path = Path(uri)
    return path if path.is_absolute() or near is None else Path(near).parent / path


@contextlib.contextmanager
def _xacro_finds(source: Path, package_paths: Mapping[str, str | Path] | None,
                 guessed: dict[str, Path]) -> Iterator[Any]:
    """xacro with ``$(find pkg)`` (and ``${find('pkg')}``) answered by
    :func:`package_directory` instead of ament_index/rospkg, restored afterwards; the
    packages found without being named (``package_paths``, ``KIT_PACKAGE_PATH``) go into
    ``guessed``."""
    import xacro
    import xacro.substitution_args as substitution

    def find(package: str) -> str:
        folder = package_directory(package, source, package_paths)
        if package not in (package_paths or {}) and package not in _environment_paths():
            guessed[package] = folder
        return str(folder)

    saved = substitution._eval_find, substitution._eval_dict.get("find")
    substitution._eval_find = find
    substitution._eval_dict["find"] = find
    try:
        yield xacro
    finally:
        substitution._eval_find = saved[0]
        substitution._eval_dict["find"] = saved[1]


def _declared_arguments(texts: Sequence[str]) -> set[str]:
    names: set[str] = set()
    for text in texts:
        body = _COMMENT.sub("", text)
        names.update(re.findall(r"<\w+:arg\s+[^>]*name\s*=\s*[\"']([^\"']+)", body))
        names.update(re.findall(r"\$\(arg\s+([^)\s]+)\s*\)", body))
    return names


def _expand(path: Path, xacro_args: Mapping[str, str],
            package_paths: Mapping[str, str | Path] | None) -> tuple[str, list[str]]:
    notes: list[str] = []
    stderr = io.StringIO()
    guessed: dict[str, Path] = {}
    with _xacro_finds(path, package_paths, guessed) as xacro:
        xacro.all_includes.clear()
        try:
            with contextlib.redirect_stderr(stderr):
                doc = xacro.process_file(str(path), mappings=dict(xacro_args))
        except BaseException as exc:
            if isinstance(exc, (KeyboardInterrupt, SystemExit)):
                raise
            inner = getattr(exc, "exc", None)
            missing = exc if isinstance(exc, _PackageNotFound) else inner
            if isinstance(missing, _PackageNotFound):
                raise RobotDescriptionError(
                    f"{path}: $(find {missing.package}): {_how_to_provide(missing.package)}"
                ) from None
            if type(exc).__name__ == "ArgException" or type(inner).__name__ == "ArgException":
                name = str(inner if inner is not None else exc).split()[-1]
                raise RobotDescriptionError(
                    f"{path}: the xacro argument {name!r} has no default; give it with "
                    f"--xacro-arg {name}:=VALUE (in Python: xacro_args={{{name!r}: ...}})"
                ) from None
            message = " ".join(str(exc).split())
            if isinstance(inner, FileNotFoundError) and guessed:
                message += "; " + "; ".join(
                    f"$(find {name}) was taken as {folder}, found in the source tree: where "
                    f"the package installs its files elsewhere, give --package-path "
                    f"{name}=DIR" for name, folder in guessed.items())
            raise RobotDescriptionError(f"{path}: xacro could not expand it: {message}") \
                from None
        includes = [str(f) for f in xacro.all_includes]
    texts = [path.read_text(encoding="utf-8")]
    for name in includes:
        with contextlib.suppress(OSError):
            texts.append(Path(name).read_text(encoding="utf-8"))
    unknown = sorted(set(xacro_args) - _declared_arguments(texts))
    if unknown:
        declared = sorted(_declared_arguments(texts))
        raise RobotDescriptionError(
            f"{path}: no xacro argument named {', '.join(map(repr, unknown))}; it takes "
            f"{', '.join(declared) if declared else 'none'}")
    for line in stderr.getvalue().splitlines():
        if line.strip():
            notes.append(f"xacro: {line.strip()}")
    if includes:
        notes.append(f"xacro included {', '.join(Path(f).name for f in includes)}")
    notes.extend(f"$(find {name}) taken as {folder}, found in the source tree"
                 for name, folder in guessed.items())
    return doc.toxml(), notes


def read_urdf(path: str | Path, xacro_args: Mapping[str, str] | None = None,
              package_paths: Mapping[str, str | Path] | None = None
              ) -> tuple[str, tuple[str, ...]]:
    """A URDF or xacro file as plain URDF XML, and notes on what was done to it.

    Parameters
    ----------
    path : str or Path
        A ``.urdf``, ``.urdf.xacro`` or ``.xacro`` file (the name does not decide: the
        content does, see :func:`is_xacro`).
    xacro_args : mapping, optional
        xacro arguments (``$(arg name)``), e.g. ``{"namespace": "tb3_0/"}``.
    package_paths : mapping, optional
        ``{"package": folder}`` for ``$(find package)`` without ROS.

    Raises
    ------
    RobotDescriptionError
        The file is missing; xacro fails (an undefined property, a missing include, an
        argument without default, a package not found, an argument the file does not
        take); the message names the file.
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RobotDescriptionError(f"{file}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotDescriptionError(f"{file}: cannot be read ({exc})") from None
    if not is_xacro(text):
        if xacro_args:
            raise RobotDescriptionError(f"{file}: is plain URDF (no xacro in it), so it takes "
                                        f"no xacro arguments; got {sorted(xacro_args)}")
        return text, ()
    expanded, notes = _expand(file, dict(xacro_args or {}), package_paths)
    args = ", ".join(f"{k}:={v}" for k, v in (xacro_args or {}).items())
    return expanded, (f"expanded with xacro{' (' + args + ')' if args else ''}", *notes)


def mesh_vertices(path: Path, scale: Sequence[float]) -> NDArray[np.float64]:
    """The (N, 3) vertices [m] of a mesh file (STL, OBJ, PLY, … as trimesh reads them),
    scaled.

    Raises
    ------
    RobotDescriptionError
        trimesh is not installed, the file is missing or holds no vertices.
    """
    try:
        import trimesh
    except ImportError:
        raise RobotDescriptionError(
            f"{path}: reading a mesh needs the trimesh package (pip install trimesh)") from None
    if not Path(path).is_file():
        raise RobotDescriptionError(f"{path}: no such mesh file")
    try:
        loaded: Any = trimesh.load(str(path), force="mesh")
        vertices = np.asarray(loaded.vertices, dtype=np.float64)
    except Exception as exc:  # trimesh raises many kinds; all mean "cannot read it"
        raise RobotDescriptionError(f"{path}: trimesh cannot read it ({exc})") from None
    if vertices.ndim != 2 or len(vertices) == 0:
        raise RobotDescriptionError(f"{path}: the mesh has no vertices")
    return vertices * np.asarray(scale, dtype=np.float64)


def _scan_model(reader: Any, connections: list[Any]) -> dict[str, Any]:
    """The lidar of a bag's first LaserScan topic (``/scan`` if there is one) as the kit's
    ``[sensors.lidar]`` keys; the rate from ``scan_time`` or, when that is 0, the stamps."""
    scans = [c for c in connections if c.msgtype == "sensor_msgs/msg/LaserScan"]
    if not scans:
        return {}
    scans.sort(key=lambda c: (c.topic != "/scan", c.topic))
    conn = scans[0]
    stamps: list[float] = []
    first: Any = None
    for _, _, raw in reader.messages(connections=[conn]):
        msg = reader.deserialize(raw, conn.msgtype)
        if first is None:
            first = msg
        stamps.append(msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec)
        if len(stamps) >= 21:
            break
    rate = 1.0 / first.scan_time if first.scan_time > 0 else (
        1.0 / float(np.median(np.diff(stamps))) if len(stamps) > 1 else 0.0)
    model: dict[str, Any] = {
        "frame_id": first.header.frame_id, "angle_min": float(first.angle_min),
        "angle_max": float(first.angle_max), "angle_increment": float(first.angle_increment),
        "range_min": float(first.range_min), "range_max": float(first.range_max),
        "topic": conn.topic}
    if math.isfinite(rate) and rate > 0:
        model["scan_rate"] = rate
    return model


def read_bag_description(path: str | Path, topic: str = "/robot_description"
                         ) -> tuple[str, dict[str, Any]]:
    """The URDF a bag carries on ``topic`` (``std_msgs/String``) and its lidar's model.

    Returns
    -------
    urdf : str
        The first message's text.
    lidar : dict
        ``frame_id``, ``angle_min``, ``angle_max``, ``angle_increment`` [rad], ``range_min``,
        ``range_max`` [m], ``scan_rate`` [Hz] and ``topic`` of the bag's first LaserScan
        topic (``/scan`` when there is one); empty if it has none.

    Raises
    ------
    RobotDescriptionError
        Not a bag; no such topic, or not a ``std_msgs/String`` one; the message names the
        bag and the topics it has.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag1 import ReaderError as Rosbag1Error
    from rosbags.rosbag2 import ReaderError as Rosbag2Error

    from kit import rosconv

    bag = Path(path)
    if not bag.exists():
        raise RobotDescriptionError(f"{bag}: no such bag")
    try:
        with AnyReader([bag], default_typestore=rosconv.typestore()) as reader:
            connections = list(reader.connections)
            wanted = [c for c in connections if c.topic == topic]
            if not wanted:
                topics = sorted({c.topic for c in connections})
                raise RobotDescriptionError(f"{bag}: no {topic} topic (the bag has "
                                            f"{', '.join(topics) or 'no topics'})")
            if wanted[0].msgtype not in ("std_msgs/msg/String", "std_msgs/String"):
                raise RobotDescriptionError(f"{bag}: {topic} is {wanted[0].msgtype}, not "
                                            f"std_msgs/msg/String")
            text = None
            for conn, _, raw in reader.messages(connections=wanted[:1]):
                message: Any = reader.deserialize(raw, conn.msgtype)
                text = str(message.data)
                break
            if text is None:
                raise RobotDescriptionError(f"{bag}: {topic} has no message")
            return text, _scan_model(reader, connections)
    except (AnyReaderError, Rosbag1Error, Rosbag2Error, FileNotFoundError) as exc:
        raise RobotDescriptionError(f"{bag}: not a bag rosbags can read ({exc})") from None
