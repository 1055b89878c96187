"""Scenario files: one TOML file fully describes one experiment.

The format is documented, with a fully commented example and a reference generated from
the schema, in ``docs/scenarios.md``. :func:`load_scenario` reads and validates a file (or
a shipped scenario name) against :class:`redservo.schema.ScenarioSpec`, without building
anything; :func:`redservo.experiment.build.build` turns it into the objects
:func:`redservo.simulation.simulate` needs and checks the geometry. Every error is a
:class:`~redservo.errors.ScenarioError` of one line that names the file, the key and what
is allowed.
"""

from __future__ import annotations

import copy
import re
import sys
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from redservo.errors import ScenarioError

if TYPE_CHECKING:  # pragma: no cover
    from redservo.schema.scenario import ScenarioSpec

__all__ = [
    "MAX_FILE_BYTES",
    "Scenario",
    "apply_overrides",
    "load_scenario",
    "parse_scenario",
    "read_toml",
    "shipped_scenarios",
]

MAX_FILE_BYTES = 10_000_000
"""Largest scenario or campaign file read (bytes): anything larger is not a set-up."""


@dataclass
class Scenario:
    """A scenario: its TOML table (as written, without defaults) and where it came from.

    Attributes:
        data: The TOML table; :attr:`spec` is its validated form (defaults applied).
        source: File path or ``shipped:NAME`` (used in every error message).
        name: ``data["name"]`` or the file name.
    """

    data: dict[str, Any]
    source: str
    name: str = field(init=False)
    _spec: ScenarioSpec | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        self.name = str(self.data.get("name") or Path(self.source).stem)

    @property
    def spec(self) -> ScenarioSpec:
        """The validated scenario (:class:`redservo.schema.ScenarioSpec`), computed once.

        Raises:
            ScenarioError: the table fails validation (names the file and the key).
        """
        if self._spec is None:
            from redservo.schema import ScenarioSpec, validate

            self._spec = validate(ScenarioSpec, self.data, self.source)
        return self._spec

    def error(self, key: str, message: str) -> ScenarioError:
        """Return a ScenarioError naming this file and ``key``."""
        return ScenarioError(f"{self.source}: key '{key}': {message}", argument=key)

    @property
    def method(self) -> str:
        """The control method name."""
        return str(self.data["control"]["method"])


def shipped_scenarios() -> dict[str, str]:
    """Return ``{name: description}`` of the scenarios shipped in ``redservo/scenarios``."""
    return shipped_descriptions("scenarios")


def shipped_descriptions(folder: str) -> dict[str, str]:
    """Return ``{name: description}`` of the TOML files in the package folder ``folder``."""
    out: dict[str, str] = {}
    root = resources.files("redservo").joinpath(*folder.split("/"))
    if not root.is_dir():  # pragma: no cover - the folders are shipped
        return out
    for entry in sorted(root.iterdir(), key=lambda p: p.name):
        if entry.name.endswith(".toml"):
            try:
                data = tomllib.loads(entry.read_text(encoding="utf-8"))
            except tomllib.TOMLDecodeError:  # pragma: no cover - shipped files are tested
                continue
            out[entry.name[:-5]] = str(data.get("description", ""))
    return out


def _decode(raw: bytes, source: str) -> str:
    """UTF-8 text of a file, or a ScenarioError saying why it is not a text file."""
    if len(raw) > MAX_FILE_BYTES:
        raise ScenarioError(
            f"{source}: file too large ({len(raw)} bytes; at most {MAX_FILE_BYTES})"
        )
    nul = raw.find(b"\x00")
    if nul >= 0:
        raise ScenarioError(
            f"{source}: not a text file (NUL byte at offset {nul}); a scenario is a UTF-8 TOML file"
        )
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ScenarioError(
            f"{source}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}, "
            f"line {line}); save the file as UTF-8"
        ) from None


def read_toml(path: Path | Any, source: str) -> dict[str, Any]:
    """Read a TOML file (a path or a package resource); one-line ScenarioError on failure."""
    try:
        size = path.stat().st_size if isinstance(path, Path) else 0
        if size > MAX_FILE_BYTES:
            raise ScenarioError(
                f"{source}: file too large ({size} bytes; at most {MAX_FILE_BYTES})"
            )
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{source}: cannot read the file: {exc.strerror or exc}") from None
    text = _decode(raw, source)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    except RecursionError:
        raise ScenarioError(f"{source}: not valid TOML: nested too deeply") from None


def locate(name_or_path: str | Path, folder: str, what: str) -> tuple[Path | Any, str, Path | None]:
    """Find a file by path or shipped name: ``(file, source, base_dir)``.

    ``shipped:NAME`` (what the messages print as the source; for campaigns also
    ``shipped:campaigns/NAME``) always names the shipped file. A bare name (no ``.toml``, no
    folder) that is a shipped name *and* exists here is decided so (docs/scenarios.md, "By
    name or by path"): a folder of that name (a run directory, say) is never a scenario, so
    the shipped one is used, with a ``note:`` on stderr saying so and how to pick a file in
    the folder; a *file* of that name is refused as ambiguous, the message naming both
    spellings (``./NAME`` for the file, ``shipped:NAME`` for the shipped one).

    Raises:
        ScenarioError: not a file and not a shipped name (the message lists them, with the
            closest one), or an ambiguous bare name.
    """
    prefix = "shipped:" if folder == "scenarios" else f"shipped:{folder.split('/')[-1]}/"
    text = str(name_or_path)
    if isinstance(name_or_path, str):
        for head in (prefix, "shipped:"):
            if text.startswith(head):
                return _shipped(text[len(head) :], folder, what, prefix, spelled=text)
    path = Path(name_or_path)
    bare = isinstance(name_or_path, str) and path.suffix != ".toml" and "/" not in text
    if bare and path.exists() and _shipped_file(folder, text).is_file():
        if path.is_file():
            raise ScenarioError(
                f"{text!r} is both a file here and a shipped {what}: give ./{text} for the "
                f"file or {prefix}{text} for the shipped {what}"
            )
        print(
            f"note: {text!r} is a folder here and a shipped {what}: using the shipped {what} "
            f"({prefix}{text}); for a file in the folder give its path, e.g. {text}/NAME.toml",
            file=sys.stderr,
        )
        return _shipped(text, folder, what, prefix, spelled=text)
    if path.suffix == ".toml" or path.exists() or len(path.parts) > 1:
        if not path.is_file():
            reason = "is a directory" if path.is_dir() else "does not exist"
            raise ScenarioError(f"{path}: no such {what} file ({reason})")
        return path, str(path), path.parent
    return _shipped(text, folder, what, prefix, spelled=text)


def _shipped_file(folder: str, name: str) -> Any:
    return resources.files("redservo").joinpath(*folder.split("/"), f"{name}.toml")


def _shipped(
    name: str, folder: str, what: str, prefix: str, *, spelled: str
) -> tuple[Any, str, None]:
    """The shipped file ``name`` of ``folder`` (see :func:`locate`)."""
    res = _shipped_file(folder, name)
    if not name or "/" in name or not res.is_file():
        from redservo.schema.base import did_you_mean

        names = list(shipped_descriptions(folder))
        raise ScenarioError(
            f"unknown {what} {spelled!r}: not a file and not a shipped {what}; "
            f"shipped {what}s: {', '.join(names) or '(none)'}{did_you_mean(name, names)}"
        )
    return res, f"{prefix}{name}", None


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a scenario by shipped name (``redservo list``) or by path to a TOML file.

    Raises:
        ScenarioError: the file is missing, not UTF-8, not valid TOML, or fails validation.
    """
    file, source, base_dir = locate(name_or_path, "scenarios", "scenario")
    return parse_scenario(read_toml(file, source), source, base_dir=base_dir)


def _resolve_urdf(table: dict[str, Any], source: str, base_dir: Path | None, prefix: str) -> None:
    """Make a relative ``robot.urdf`` path (or ``robot.file`` of ``kind = "mjcf"``) absolute
    (relative to the scenario file); a bare name must be a shipped file."""
    robot = table.get("robot")
    if not isinstance(robot, dict):
        return
    key = "file" if robot.get("kind") == "mjcf" else "urdf"
    if not isinstance(robot.get(key), str):
        return
    value: str = robot[key]
    if "/" not in value and "\\" not in value and not value.endswith((".urdf", ".xml")):
        from redservo.robots.mjcf import SHIPPED_MJCFS
        from redservo.robots.urdf import SHIPPED_URDFS
        from redservo.schema.base import unknown_name

        shipped = list(SHIPPED_URDFS if key == "urdf" else SHIPPED_MJCFS)
        if value.strip().lower() not in shipped:
            what = "shipped URDF" if key == "urdf" else "shipped MJCF"
            raise ScenarioError(
                f"{source}: key '{prefix}robot.{key}': {unknown_name(what, value, shipped)}"
                f" (or give a path to a {'.urdf' if key == 'urdf' else '.xml'} file)",
                argument=f"{prefix}robot.{key}",
            )
        return
    path = Path(value)
    relative = not path.is_absolute()
    if relative:
        path = (base_dir or Path.cwd()) / path
    if not path.is_file():
        where = "is a directory" if path.is_dir() else "does not exist"
        hint = (
            f"; {value!r} is read relative to "
            + ("the scenario file's folder" if base_dir is not None else "the current folder")
            if relative
            else ""
        )
        raise ScenarioError(
            f"{source}: key '{prefix}robot.{key}': no such file {str(path)!r} ({where}{hint})",
            argument=f"{prefix}robot.{key}",
        )
    robot[key] = str(path.resolve())


def parse_scenario(
    data: Mapping[str, Any],
    source: str = "<scenario>",
    *,
    base_dir: Path | None = None,
    key_prefix: str = "",
) -> Scenario:
    """Validate a scenario table (keys, types, ranges, names, references) and return it.

    Nothing is built: geometry (``q0`` within the robot's limits, a target in front of the
    camera and in the image) is checked by :func:`redservo.experiment.build.build`.

    Args:
        data: The TOML table.
        source: Where it came from (used in error messages).
        base_dir: Directory of the file, against which ``robot.urdf`` is resolved
            (None: the current directory).
        key_prefix: Put before every key in error messages (``overrides.`` when a
            campaign file overrides its base scenario).

    Raises:
        ScenarioError: naming ``source``, the key and what is allowed.
    """
    from redservo.schema import ScenarioSpec, validate

    table = copy.deepcopy(dict(data))
    _resolve_urdf(table, source, base_dir, key_prefix)
    for section, key in (("camera", "file"), ("collision", "srdf")):
        resolve_file_key(table, section, key, source, base_dir, key_prefix)
    scenario = Scenario(table, source)
    scenario._spec = validate(ScenarioSpec, table, source, key_prefix)
    return scenario


def resolve_file_key(
    table: dict[str, Any],
    section: str,
    key: str,
    source: str,
    base_dir: Path | None,
    prefix: str = "",
) -> None:
    """Make a scenario's relative file path ``[section] key`` (``camera.file``, an intrinsics
    file; ``collision.srdf``, the robot's SRDF) absolute, relative to the scenario file
    (``base_dir`` None: the current directory), and check that it exists.

    Raises:
        ScenarioError: the file does not exist (names the scenario and the key).
    """
    sub = table.get(section)
    if not isinstance(sub, dict) or not isinstance(sub.get(key), str):
        return
    path = Path(sub[key]).expanduser()
    relative = not path.is_absolute()
    if relative:
        path = (base_dir or Path.cwd()) / path
    if not path.is_file():
        where = "is a directory" if path.is_dir() else "does not exist"
        if relative:  # an absolute path is not read relative to anything
            folder = "the scenario file's folder" if base_dir is not None else "the current folder"
            where += f"; {sub[key]!r} is read relative to {folder}"
        raise ScenarioError(
            f"{source}: key '{prefix}{section}.{key}': no such file {str(path)!r} ({where})",
            argument=f"{prefix}{section}.{key}",
        )
    sub[key] = str(path.resolve())


_INDEXED_KEY = re.compile(r"([A-Za-z_][A-Za-z0-9_-]*)\[([0-9]+)\]")
"""A ``--set`` path segment ``name[i]``: entry i of an array of tables."""


def apply_overrides(scenario: Scenario, assignments: list[str]) -> Scenario:
    """Return a new scenario with ``key=value`` overrides applied (``--set`` on the CLI).

    Keys are dotted paths (``control.lam``, ``control.options.alpha``,
    ``simulation.max_iterations``); a path segment ``name[i]`` selects entry ``i``
    (0-based) of an array of tables (``features[0].variant``,
    ``objects[1].radius``); values are TOML values (``0.5``, ``"gpm"``,
    ``[0.1, 0.2]``, ``true``); a bare word is taken as a string.

    Raises:
        ScenarioError: malformed assignment, an index that does not name an existing
            table of an array, or the result fails validation.
    """
    data = copy.deepcopy(scenario.data)
    for item in assignments:
        if "=" not in item:
            raise ScenarioError(f"--set {item!r}: expected key=value, e.g. control.lam=0.5")
        key, raw = item.split("=", 1)
        key = key.strip()
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except (tomllib.TOMLDecodeError, RecursionError):
            value = raw.strip()
        node: dict[str, Any] = data
        parts = key.split(".")
        if not all(parts):
            raise ScenarioError(f"--set {item!r}: empty key segment in {key!r}")
        for part in parts[:-1]:
            indexed = _INDEXED_KEY.fullmatch(part)
            if indexed is not None:
                name, i = indexed.group(1), int(indexed.group(2))
                seq = node.get(name)
                if not isinstance(seq, list) or i >= len(seq) or not isinstance(seq[i], dict):
                    size = len(seq) if isinstance(seq, list) else 0
                    allowed = f"indices 0 to {size - 1}" if size else f"no '{name}' tables"
                    raise ScenarioError(f"--set {item!r}: '{part}' does not exist; {allowed}")
                node = seq[i]
                continue
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise ScenarioError(f"--set {item!r}: '{part}' is not a table")
            node = nxt
        node[parts[-1]] = value
    out = parse_scenario(data, f"{scenario.source} (with --set {' '.join(assignments)})")
    out.name = str(data.get("name") or scenario.name)  # not the stem of the longer source
    return out
