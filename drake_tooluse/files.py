"""Atomic file writes: a result is either whole on disk or not there at all.

Files (`atomic_write_*`: text, bytes, JSON, PNG images and matplotlib figures) are written to
a temporary sibling and renamed over the target; directories (`atomic_dir`) are written into
a temporary sibling directory that takes the target's place only when complete (a new target
by one rename, an existing one by one atomic exchange, Linux's `renameat2(RENAME_EXCHANGE)`).
Every file is flushed to disk before the rename that publishes it.

A temporary sibling is named `.<name>.tmp-<pid>@<host>.<random>`: a process killed while
writing leaves one behind, and `remove_orphans` (called by `atomic_dir` on its folder and by
the commands that own a folder) deletes those whose process on this host is gone.

The checks for output paths (`check_output_file`, `check_output_dir`) run where a command
starts, before any work, and `run_lock` keeps two processes out of one run directory.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import fcntl
import io
import json
import math
import os
import re
import shutil
import socket
import tempfile
from pathlib import Path

import cv2
import numpy as np
import yaml

from drake_tooluse.validation import EnvironmentProblem, clipped, shown

_HOST = re.sub(r"[^A-Za-z0-9_-]", "_", socket.gethostname()) or "host"
# .<name>.tmp-<pid>@<host>.<random>: the random part is mkstemp/mkdtemp's (8 of [a-z0-9_]).
_ORPHAN = re.compile(r"^\..+\.tmp-(?P<pid>\d+)@(?P<host>[A-Za-z0-9_-]+)\.[a-z0-9_]+$")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _tmp_prefix(name: str) -> str:
    return f".{name}.tmp-{os.getpid()}@{_HOST}."


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def remove_orphans(directory: str | Path) -> list[Path]:
    """Deletes the temporary files and directories a killed writer left in `directory` (those
    of processes of this host that are no longer running); returns what it deleted."""
    directory = Path(directory)
    removed = []
    try:
        entries = list(directory.iterdir())
    except (FileNotFoundError, NotADirectoryError):
        return removed
    for entry in entries:
        m = _ORPHAN.match(entry.name)
        if m is None or m["host"] != _HOST or _pid_alive(int(m["pid"])):
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)
        else:
            entry.unlink(missing_ok=True)
        removed.append(entry)
    return removed


def _fsync_dir(directory: Path) -> None:
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _fsync_tree(root: Path) -> None:
    """Flushes every file below `root` to disk; a file made private (0600, as mkstemp and some
    writers make them) gets the usual file mode."""
    mode = 0o666 & ~_umask()
    for folder, _, names in os.walk(root):
        for name in names:
            path = os.path.join(folder, name)
            if os.path.islink(path):
                continue
            if os.stat(path).st_mode & 0o777 == 0o600:
                os.chmod(path, mode)
            with open(path, "rb") as f:
                os.fsync(f.fileno())
        _fsync_dir(Path(folder))


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode())


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{str(path)!r} is a directory; give a file name")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_tmp_prefix(path.name))
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual file mode
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)
    return path


def _strict_json(value):
    """`value` with every non-finite float replaced by None (JSON has no NaN or Infinity)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict_json(v) for v in value]
    return value


def to_json(data, indent: int | None = 2) -> str:
    """Strict JSON text (no NaN or Infinity, which JSON does not have: they become null)."""
    return json.dumps(_strict_json(data), indent=indent, allow_nan=False)


def atomic_write_json(path: str | Path, data) -> Path:
    return atomic_write_text(path, to_json(data) + "\n")


def atomic_write_image(path: str | Path, image: np.ndarray, bgr: bool = False) -> Path:
    """Writes an (H, W, 3 or 4) uint8 image as a PNG: RGB(A) channels, or OpenCV's BGR order
    with `bgr`; an alpha channel is dropped."""
    pixels = np.ascontiguousarray(np.asarray(image)[:, :, :3])
    ok, png = cv2.imencode(".png", pixels if bgr else cv2.cvtColor(pixels, cv2.COLOR_RGB2BGR))
    if not ok:
        raise RuntimeError(f"could not encode the image for {str(path)!r} as PNG")
    return atomic_write_bytes(path, png.tobytes())


def atomic_write_figure(path: str | Path, figure, dpi: int = 120) -> Path:
    """Writes a matplotlib figure as a PNG."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi)
    return atomic_write_bytes(path, buffer.getvalue())


_OS_ERROR = re.compile(r"\bos error (\d+)\b")
_NEARLY_FULL = 1 << 20  # bytes: a disk with less free space than this is full for a writer


def _disk_full(path: Path) -> bool:
    folder = path if path.is_dir() else path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        stats = os.statvfs(folder)
    except OSError:
        return False
    return stats.f_bavail * stats.f_frsize < _NEARLY_FULL


@contextlib.contextmanager
def library_write(path: str | Path):
    """A library (torch, safetensors) writes `path` in the block: when it fails for a reason of
    the system (a full disk, a quota, an I/O error), which it reports as an error of its own
    kind (torch's RuntimeError, safetensors' SafetensorError), that is raised as the OSError it
    is, naming `path` (a command's exit 2, not a bug). Its other errors pass as they are."""
    path = Path(path)
    try:
        yield
    except OSError:
        raise
    except Exception as e:
        match = _OS_ERROR.search(str(e))
        if match is not None:
            code = int(match[1])
        elif _disk_full(path):
            code = errno.ENOSPC
        else:
            raise
        raise OSError(code, os.strerror(code), str(path)) from e


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _renameat2():
    try:
        f = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return None
    f.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    f.restype = ctypes.c_int
    return f


_RENAMEAT2 = _renameat2()


def _exchange(a: Path, b: Path) -> bool:
    """Swaps the directories `a` and `b` in one atomic step; False where the system or the
    file system cannot."""
    if _RENAMEAT2 is None:
        return False
    if _RENAMEAT2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _old_name(target: Path) -> Path:
    return target.with_name(f".{target.name}.old")


def discard_dir(path: str | Path) -> None:
    """Removes a directory so that a kill part-way leaves no half-deleted copy under its name:
    it is renamed to an orphan's name first, then deleted."""
    path = Path(path)
    if not path.exists():
        return
    doomed = Path(tempfile.mkdtemp(dir=path.parent, prefix=_tmp_prefix(path.name)))
    os.rename(path, doomed / path.name)
    shutil.rmtree(doomed, ignore_errors=True)


def recover_dir(target: str | Path) -> bool:
    """Where an earlier replace was interrupted between its two renames (on a file system
    without an atomic exchange), puts the complete previous directory back; True if it did."""
    target = Path(target)
    old = _old_name(target)
    if not target.exists() and old.is_dir():
        os.rename(old, target)
        return True
    return False


@contextlib.contextmanager
def atomic_dir(target: str | Path, replace: bool = False):
    """Yields a temporary sibling directory to write a directory's files into; on success it
    takes the place of `target`, on an error it is removed: the directory is either complete
    or as it was. Without `replace`, `target` must not exist or be empty (a run directory is
    never overwritten); with it, a complete old `target` is replaced (a policy) in one atomic
    exchange where the file system has it (else two renames, which `recover_dir` repairs)."""
    target = Path(target)
    recover_dir(target)
    if target.exists() and not target.is_dir():
        raise FileExistsError(f"{str(target)!r} exists and is a file; give a new directory")
    if not replace and target.exists() and any(target.iterdir()):
        raise FileExistsError(f"{str(target)!r} exists and is not empty; give a new directory")
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_orphans(target.parent)
    tmp = Path(tempfile.mkdtemp(dir=target.parent, prefix=_tmp_prefix(target.name)))
    try:
        yield tmp
        tmp.chmod(0o777 & ~_umask())  # mkdtemp makes 0700; give the usual directory mode
        _fsync_tree(tmp)
        if not target.exists():
            os.rename(tmp, target)
        elif not any(target.iterdir()):
            os.rename(tmp, target)  # over an empty directory
        elif _exchange(tmp, target):
            shutil.rmtree(tmp, ignore_errors=True)  # it holds the old one now
        else:
            old = _old_name(target)
            if old.exists():
                discard_dir(old)
            os.rename(target, old)
            os.rename(tmp, target)
            discard_dir(old)
        _fsync_dir(target.parent)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


# -- reading YAML -------------------------------------------------------------------------

MAX_YAML_BYTES = 1 << 20  # a scenario or hyperparameter file is a few kB


class _StrictLoader(yaml.SafeLoader):
    """PyYAML's safe loader, refusing a key given twice in one mapping (PyYAML keeps the
    last one silently)."""

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                first = seen.get(key)
            except TypeError:  # an unhashable key: the base class reports it
                break
            if first is not None:
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f"key {key!r} is given twice (first on line {first + 1})",
                    key_node.start_mark,
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def read_yaml(path: str | Path, what: str = "YAML file", max_bytes: int = MAX_YAML_BYTES):
    """Parses a YAML file safely (no tags that build Python objects), refusing files larger than
    `max_bytes` before reading them, duplicate keys, keys that are not names (`1:`, `true:`)
    and nesting deeper than `MAX_NESTING`; errors name the file."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {str(path)!r}")
    size = path.stat().st_size
    if size > max_bytes:
        raise ValueError(
            f"{what} {str(path)!r} is {size / 2**20:.1f} MB; at most {max_bytes / 2**20:g} MB "
            "is allowed"
        )
    where = f"invalid {what} {str(path)!r}"
    try:
        value = yaml.load(path.read_text(), Loader=_StrictLoader)  # noqa: S506 (a SafeLoader)
    except UnicodeDecodeError as e:
        raise ValueError(f"{where}: not text ({e})") from None
    except yaml.YAMLError as e:
        raise ValueError(f"{where}: not YAML: {_yaml_error(e)}") from None
    except RecursionError:
        raise ValueError(f"{where} is nested more than {MAX_NESTING} levels deep") from None
    except ValueError as e:  # a number Python refuses to read (an integer of 4300+ digits)
        raise ValueError(f"{where}: {_number_error(e)}") from None
    check_plain_data(value, where, names_only=True)
    return value


# -- reading JSON -------------------------------------------------------------------------

MAX_JSON_BYTES = 1 << 20  # a policy.json, a run configuration or a checkpoint's state: kB
MAX_NESTING = 32  # levels of lists and mappings in a file or option a person writes


def _number_error(e: ValueError) -> str:
    if "integer string conversion" in str(e):
        return "a number has more than 4300 digits"
    return clipped(e)


def check_plain_data(value, where: str, names_only: bool = False):
    """`value` (parsed JSON or YAML) nested at most `MAX_NESTING` levels deep; with
    `names_only`, every mapping's keys strings. Else a ValueError starting with `where`."""
    stack = [(value, 1, "")]
    while stack:
        item, depth, at = stack.pop()
        if isinstance(item, dict):
            children = item.items()
        elif isinstance(item, list):
            children = enumerate(item)
        else:
            continue
        if depth > MAX_NESTING:
            raise ValueError(f"{where} is nested more than {MAX_NESTING} levels deep (at {at})")
        for key, child in children:
            if isinstance(item, dict) and names_only and not isinstance(key, str):
                raise ValueError(
                    f"{where}: the key {shown(key)} {f'in {at} ' if at else ''}is not a name "
                    "(write it as a string)"
                )
            stack.append((child, depth + 1, f"{at}.{key}" if at else str(key)))
    return value


def parse_json(text: str, where: str):
    """JSON `text` as Python values; bad JSON, an integer of more than 4300 digits and nesting
    deeper than `MAX_NESTING` are a ValueError starting with `where` (the file or option:
    "--hyperparams", "corrupt policy metadata 'DIR/policy.json'")."""
    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{where} is not valid JSON ({e})") from None
    except RecursionError:
        raise ValueError(f"{where} is nested more than {MAX_NESTING} levels deep") from None
    except ValueError as e:
        raise ValueError(f"{where}: {_number_error(e)}") from None
    return check_plain_data(value, where)


def read_json(path: str | Path, what: str, max_bytes: int = MAX_JSON_BYTES):
    """A JSON file's values; a file larger than `max_bytes` is refused before it is read, and
    every error (`parse_json`'s, not text) names `what` and the file."""
    path = Path(path)
    size = path.stat().st_size
    if size > max_bytes:
        raise ValueError(
            f"{what} {str(path)!r} is {size / 2**20:.1f} MB; at most {max_bytes / 2**20:g} MB "
            "is allowed"
        )
    try:
        text = path.read_text()
    except UnicodeDecodeError as e:
        raise ValueError(f"corrupt {what} {str(path)!r}: not text ({e})") from None
    return parse_json(text, f"corrupt {what} {str(path)!r}")


def _yaml_error(e: yaml.YAMLError) -> str:
    """A YAML error on one line: what is wrong and where."""
    if isinstance(e, yaml.MarkedYAMLError) and e.problem_mark is not None:
        mark = e.problem_mark
        context = f"{e.context}: " if e.context else ""
        return f"{context}{e.problem} (line {mark.line + 1}, column {mark.column + 1})"
    return " ".join(str(e).split())


# -- output paths ---------------------------------------------------------------------------


def _writable_parent(path: Path, option: str) -> None:
    """The nearest existing ancestor of `path` must be a writable directory."""
    parent = path.parent
    while not parent.exists():
        if parent == parent.parent:
            break
        parent = parent.parent
    if not parent.is_dir():
        raise ValueError(f"{option} {str(path)!r}: {str(parent)!r} is a file, not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {str(path)!r}: the directory {str(parent)!r} is not writable")
    _probe_write(parent, option, path)


def _probe_write(directory: Path, option: str, path: Path) -> None:
    """Creates and removes a file in `directory`: what `os.access` cannot tell (a root user
    in /proc, a read-only mount) fails here, before the work, not at the atomic write after
    it with an internal temporary name."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".probe.tmp-", dir=directory)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise ValueError(
            f"{option} {str(path)!r}: cannot write in {str(directory)!r} ({e.strerror})"
        ) from None


def check_output_file(path, option: str, suffix: str | None = None) -> Path:
    """A file a command will write: not a directory, in a directory it can write (made if
    missing); with `suffix`, its name must end with it. Raises ValueError naming `option`."""
    path = Path(path)
    if suffix is not None and path.suffix.lower() != suffix:
        raise ValueError(f"{option} {str(path)!r} must be a {suffix} file")
    if path.is_dir():
        raise ValueError(f"{option} {str(path)!r} is a directory; give a file name")
    if path.exists() and not os.access(path, os.W_OK):
        raise ValueError(f"{option} {str(path)!r} exists and is not writable")
    _writable_parent(path, option)
    return path


def check_output_dir(path, option: str, must_be_new: bool = True) -> Path:
    """A directory a command will write: not a file; with `must_be_new`, absent or empty; in a
    writable directory. Raises FileExistsError (a file, or not empty) or ValueError naming
    `option`."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise FileExistsError(f"{option} {str(path)!r} is a file; give a directory")
    if path.is_dir():
        if must_be_new and any(path.iterdir()):
            raise FileExistsError(
                f"{option} {str(path)!r} exists and is not empty; give a new directory"
            )
        if not os.access(path, os.W_OK | os.X_OK):
            raise ValueError(f"{option} {str(path)!r} is not writable")
        _probe_write(path, option, path)
        return path
    _writable_parent(path, option)
    return path


def lock_holder(directory: str | Path) -> int | None:
    """The pid that `run_lock` wrote in `directory`, if that process is alive; else None (no
    lock file, or its holder has ended: the lock went with it)."""
    try:
        pid = int((Path(directory) / ".lock").read_text().strip())
    except (OSError, ValueError):
        return None
    return pid if _pid_alive(pid) else None


@contextlib.contextmanager
def run_lock(directory: str | Path):
    """Holds an exclusive lock on `directory` (its `.lock` file) while the block runs; a
    second process is refused with the holder's pid. The lock goes with the process, so a
    killed run leaves nothing to clear."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / ".lock"
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666 & ~_umask())
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "?"
            raise EnvironmentProblem(
                f"{str(directory)!r} is in use by another process (pid {holder}); wait for it "
                "to end or stop it first"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield
    finally:
        os.close(fd)
