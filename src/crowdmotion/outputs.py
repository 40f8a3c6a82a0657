"""Write a run's files: trajectories in the requested formats, summary.json, figures and
the HTML player, into an output folder the run holds alone (a lock) and that lists the
files it wrote (manifest.json), so that ``--overwrite`` removes those and nothing else."""

from __future__ import annotations

import json
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no folder lock
    fcntl = None

from crowdmotion import __version__
from crowdmotion._precompile import cores
from crowdmotion.io.atomic import TEMP_NAME, WriteError, atomic_path, remove_stale_temps
from crowdmotion.io.longform import json_text
from crowdmotion.registry import get_method

# what ``crowdmotion run`` and the commands that read a run folder write into it
RUN_FILES = ("trajectories.parquet", "trajectories.csv", "trajectories.csv.meta.json", "trajectories.sqlite",
             "trajectories.usdc", "trajectories.usda", "summary.json", "report.json", "paths.png", "journeys.png", "values.png",
             "snapshots.png", "field.png", "density.png", "formation.gif", "animation.mp4", "animation.gif",
             "view.html")
MANIFEST = "manifest.json"  # the files a run wrote, and whether it finished writing them
LOCK = ".crowdmotion.lock"  # held (flock) by the run writing into the folder
# the picture files each name in [output] plots may give, whatever the method
PICTURE_FILES = {"paths": ("paths.png", "journeys.png"), "values": ("values.png", "field.png"),
                 "snapshots": ("snapshots.png", "formation.gif"), "player": ("view.html",)}


class OutputFolderError(ValueError):
    """An output folder a run cannot use: not writable, in use by another run, holding an
    earlier run, or holding files no run listed."""


class EarlierRunError(OutputFolderError):
    """The output folder holds an earlier run's files and no ``--overwrite`` was given:
    ``run`` refuses it, ``validate`` (which writes nothing) notes it. ``what``: "an
    earlier run" or "an earlier run that did not finish writing"; ``names``: its files,
    shortened for a message."""

    def __init__(self, out: Path, what: str, names: str):
        self.out, self.what, self.names = out, what, names
        super().__init__(f"output folder {out} holds {what} ({names}): pass --overwrite to replace it (only the files "
                         f"its {MANIFEST} lists are removed), or choose another folder with -o")


class PictureError(RuntimeError):
    """Drawing a run's pictures failed (a bug of ours): the run's trajectories and
    summary.json are kept, whole (``written``), and the pictures that did draw."""

    def __init__(self, cause: BaseException, written: list[Path]):
        super().__init__(f"{type(cause).__name__}: {cause}")
        self.cause, self.written = cause, written


def folder_inside(root, name: str) -> Path:
    """``root / name``, the folder a name gives (a scenario's out/<name>, a demo scene's
    subfolder), refused unless, resolved, it lies strictly inside ``root``: a name such
    as ``..``, ``../x`` or ``/tmp/x`` must never send a run's files elsewhere."""
    root = Path(root)
    folder = root / name
    try:
        inside = root.resolve() in folder.resolve().parents
    except (OSError, ValueError, RuntimeError):  # a NUL in the name, a symlink loop
        inside = False
    if not inside:
        raise OutputFolderError(f"the name {name!r} would put the output folder outside {root}/ "
                                f"(at {str(folder)!r}); give a plain folder name, or a folder with -o")
    return folder


def _plain_name(name) -> bool:
    """A file name a manifest may list: one name inside its folder, nothing above or below."""
    return (isinstance(name, str) and name not in ("", ".", "..", MANIFEST) and "/" not in name
            and "\\" not in name and "\x00" not in name)


def read_manifest(folder) -> dict | None:
    """The manifest of the run in ``folder`` (``files``: the names it wrote; ``complete``:
    whether it finished writing them; ``partial``: stopped early), or None where the folder
    has none. A manifest that cannot be read is refused, naming it."""
    path = Path(folder) / MANIFEST
    if not os.path.lexists(path):
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(data, dict) or not isinstance(data.get("files"), list):
            raise ValueError("it lists no files")
        if not all(_plain_name(n) for n in data["files"]):
            raise ValueError("it lists a name outside its folder")
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise OutputFolderError(f"{path} is not a crowdmotion run manifest ({reason}): remove the folder's files "
                                f"yourself, or choose another folder with -o") from None
    return data


def _own(name: str) -> bool:
    """Whether a name in an output folder is crowdmotion's own bookkeeping rather than a
    file of a run: the lock, and temporary files of writes (or probes) that never finished."""
    return name == LOCK or bool(TEMP_NAME.match(name)) or name.startswith(".crowdmotion-probe-")


def _names(paths: list[Path], most: int = 4) -> str:
    return ", ".join(p.name for p in paths[:most]) + (", ..." if len(paths) > most else "")


def _earlier_run(out: Path, overwrite: bool) -> list[Path]:
    """The files ``--overwrite`` removes from folder ``out`` (those its manifest lists, the
    manifest last), or a refusal: an earlier run without ``overwrite``, files without a
    manifest in any case."""
    manifest = read_manifest(out)
    if manifest is None:
        strangers = sorted(out / e.name for e in os.scandir(out) if not _own(e.name))
        if strangers:
            raise OutputFolderError(f"output folder {out} holds files no crowdmotion run listed ({_names(strangers)}; "
                                    f"no {MANIFEST}): --overwrite removes only the files an earlier run's "
                                    f"{MANIFEST} lists; empty the folder yourself, or choose another folder with -o")
        return []
    listed = [out / n for n in dict.fromkeys(manifest["files"]) if os.path.lexists(out / n)] + [out / MANIFEST]
    if not overwrite:
        what = "an earlier run" if manifest.get("complete") else "an earlier run that did not finish writing"
        raise EarlierRunError(out, what, _names(listed))
    return listed


def _holder(out: Path) -> str:
    """' (process N)' for the run holding folder ``out``, as its lock file says, or ''."""
    try:
        pid = int((out / LOCK).read_text().strip())
    except (OSError, ValueError):
        return ""
    return f" (process {pid})"


def _busy_error(out: Path) -> OutputFolderError:
    return OutputFolderError(f"output folder {out} is in use by another crowdmotion run{_holder(out)}: wait for it "
                             f"to finish, or choose another folder with -o")


def _busy(out: Path) -> bool:
    """Whether another process holds the lock of folder ``out`` (probed, not taken)."""
    if fcntl is None:
        return False
    try:
        fd = os.open(out / LOCK, os.O_RDONLY | os.O_CLOEXEC)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    except BlockingIOError:
        return True
    except OSError:  # a file system without locks
        return False
    finally:
        os.close(fd)


def check_writable(out) -> None:
    """Refuse a folder ``out`` that is a file, or that could not be made or written; creates nothing."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputFolderError(f"output folder {out} is a file, not a folder")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        raise OutputFolderError(f"cannot make output folder {out}: {probe} is a file")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputFolderError(f"cannot write to output folder {out}: {probe} is not writable")


def check_output_folder(out, overwrite: bool = False) -> list[Path]:
    """Refuse a folder ``run`` could not write, one another run is writing into, one holding
    an earlier run's files (unless ``overwrite``: :class:`EarlierRunError`) and one holding
    files no run's manifest lists; creates nothing. Returns the files ``overwrite`` would
    remove."""
    out = Path(out)
    check_writable(out)
    if not out.is_dir():
        return []
    if _busy(out):
        raise _busy_error(out)
    return _earlier_run(out, overwrite)


def _lock(out: Path) -> int | None:
    """Take the lock of folder ``out`` (its lock file, made if missing, holding this
    process's id); the open file, or None where the file system has no locks. A lock
    another process holds is refused; one whose file its last holder removed meanwhile is
    taken afresh."""
    if fcntl is None:
        return None
    path = out / LOCK
    for _ in range(100):
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        except FileNotFoundError:  # the folder went with the run that held it: made again
            out.mkdir(parents=True, exist_ok=True)
            continue
        except OSError as exc:
            raise OutputFolderError(f"cannot write to output folder {out}: {exc.strerror or exc}") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise _busy_error(out) from None
        except OSError:  # a file system without locks: the run goes on unlocked
            os.close(fd)
            return None
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            return fd
        os.close(fd)  # the holder removed this file as it let go: take the new one
    raise _busy_error(out)


def _unlock(out: Path, fd: int | None) -> None:
    """Let go of the lock taken by :func:`_lock` (for every process that shares it, such
    as a forked child still alive), removing its file first."""
    if fd is None:
        return
    try:
        os.unlink(out / LOCK)
    except OSError:
        pass
    try:
        fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


class RunFolder(os.PathLike):
    """An output folder held by one run from before it simulates until its files are
    written: locked against other runs, cleared of the earlier run's files. Use it as a
    path; :meth:`release` (or the end of its ``with`` block) lets it go, removing the
    folder again if it made it and nothing was written."""

    def __init__(self, path: Path, fd: int | None, created: bool):
        self.path = path
        self._fd = fd
        self._created = created

    def __fspath__(self) -> str:
        return os.fspath(self.path)

    def __repr__(self) -> str:
        return f"RunFolder({str(self.path)!r})"

    def __str__(self) -> str:
        return str(self.path)

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self) -> None:
        fd, self._fd = self._fd, None
        if fd is None and not self._created:
            return
        _unlock(self.path, fd)
        if self._created:
            self._created = False
            try:
                self.path.rmdir()  # only if empty: a run stopped before writing leaves nothing
            except OSError:
                pass


def claim_output_folder(out, overwrite: bool = False) -> RunFolder:
    """Make ``out`` ready for one run before simulating, and hold it: checked (as
    :func:`check_output_folder`), created, locked (a second run into it is refused while
    this one lasts), checked again under the lock, cleared of temporary files that writes
    killed outright left and, with ``overwrite``, of the files the earlier run's manifest
    lists (nothing else). Returns the held :class:`RunFolder`."""
    out = Path(out)
    check_output_folder(out, overwrite)  # refused before anything is made
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputFolderError(f"cannot make output folder {out}: {exc.strerror or exc}") from None
    folder = RunFolder(out, None, created)
    try:
        folder._fd = _lock(out)
        old = _earlier_run(out, overwrite)  # again, now that no other run can write here
        remove_stale_temps(out)
        for probe in out.glob(".crowdmotion-probe-*"):  # an earlier version's write probe, left by a killed run
            probe.unlink(missing_ok=True)
        for f in old:  # the manifest last: a removal cut short is finished by the next --overwrite
            try:
                f.unlink()
            except FileNotFoundError:
                pass
            except OSError as exc:
                raise OutputFolderError(f"cannot remove {f} of the earlier run: {exc.strerror or exc}") from None
    except BaseException:
        folder.release()
        raise
    return folder


def _write_manifest(out: Path, files: list[str], complete: bool, partial: bool) -> None:
    with atomic_path(out / MANIFEST) as tmp:
        tmp.write_text(json.dumps({"crowdmotion": __version__, "complete": complete, "partial": partial,
                                   "files": list(dict.fromkeys(files))}, indent=2) + "\n")


@contextmanager
def adding_to_run(folder) -> Iterator[Callable[[Path], None]]:
    """For a command that writes into a run's folder afterwards (report.json, an export, a
    video): while ``folder`` holds a run (its manifest), hold its lock (refused while a run
    writes there) and list each file given to the yielded ``add(path)`` in the manifest,
    so that ``run --overwrite`` removes it with the rest. Elsewhere (or ``folder`` None)
    ``add`` does nothing."""
    folder = Path(folder) if folder is not None else None
    manifest = read_manifest(folder) if folder is not None and folder.is_dir() else None
    if manifest is None:
        yield lambda path: None
        return
    fd = _lock(folder)  # refused while a run writes there
    added: list[str] = []

    def add(path) -> None:
        path = Path(path)
        if path.parent.resolve() == folder.resolve() and _plain_name(path.name):
            added.append(path.name)

    try:
        manifest = read_manifest(folder)  # as it is now that the folder is held
        yield add
    finally:  # what was written is listed even if a later file failed
        try:
            if added and manifest is not None:
                _write_manifest(folder, manifest["files"] + added, bool(manifest.get("complete")),
                                bool(manifest.get("partial")))
        finally:
            _unlock(folder, fd)


def run_files(formats, plots) -> list[str]:
    """The names a run writing trajectories in ``formats`` and the pictures ``plots`` may
    leave in its folder (more pictures than a method draws: what it might)."""
    names = []
    for fmt in formats:
        names.append(f"trajectories.{fmt}")
        if fmt == "csv":
            names.append("trajectories.csv.meta.json")
    names.append("summary.json")
    names += [f for p in plots for f in PICTURE_FILES.get(p, ())]
    return names


def _remove(out: Path, names: list[str]) -> None:
    """Remove what there is of ``names`` in ``out`` (the manifest last), as far as possible."""
    for name in sorted(dict.fromkeys(names), key=lambda n: n == MANIFEST):
        try:
            (out / name).unlink()
        except OSError:
            pass


def write_run(result, out, plots=None, pictures=None) -> list[Path]:
    """Write everything a scenario asks for into folder ``out``; returns the paths.
    ``plots`` (names as in [output] plots) replaces the scenario's own list.
    ``pictures``: a started :class:`~crowdmotion.render.background.PictureProcess` that
    draws the pictures, in parts side by side, while this process writes the
    trajectories and summary.json.

    The folder's manifest.json lists the files before the first is written and says when
    all are: a run is left whole, or (an error, a full disk, a second Ctrl-C) with none
    of its files; a picture that fails to draw (a bug of ours) raises
    :class:`PictureError` after the run's data files (and the pictures that did draw)
    are written whole and listed; a process killed outright leaves a manifest that says it did not
    finish, which ``--overwrite`` clears. A run stopped early is whole too, its frames so
    far marked ``partial`` in summary.json, the trajectories and the manifest."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    spec = result.scenario.spec
    plots = spec.output.plots if plots is None else list(plots)
    partial = bool(result.summary.get("partial", False))
    planned = run_files(spec.output.formats, plots)
    run = (spec.method, result.scenario.scene, result.extras, result.trajectories, out)
    pictures = pictures if plots else None  # nothing to draw: no job for it
    drawn: list[Path] = []
    _write_manifest(out, planned, complete=False, partial=partial)  # first: what a killed run leaves is listed
    try:
        if pictures is not None:
            if "player" in plots:  # derived once, before the run goes to the picture process: player and files share them
                result.trajectories.locomotion()
            split = getattr(get_method(spec.method).module, "PICTURE_PARTS", None)
            pictures.submit(draw_pictures, [(*run, part, spec.name) for part in picture_parts(plots, cores(), split)])
        written = [result.trajectories.save(out / f"trajectories.{fmt}") for fmt in spec.output.formats]
        summary = {"scenario": spec.name, "seed": result.seed, **result.summary}
        with atomic_path(out / "summary.json") as tmp:
            tmp.write_text(json_text(summary, indent=2))
        written.append(out / "summary.json")
        failed = None
        try:
            drawn = pictures.result() if pictures is not None else draw_pictures(*run, plots, spec.name)
        except Exception as exc:  # noqa: BLE001 - a picture's bug must not lose the run (a full disk still does)
            if isinstance(exc, OSError):
                raise
            failed = exc
            if pictures is not None:
                pictures.close()  # the other parts stopped too, their writes in progress removed
                remove_stale_temps(out)
            data = {p.name for p in written}
            drawn = [out / n for n in planned if os.path.lexists(out / n)
                     and n not in data and not n.endswith(".meta.json")]
        names = [p.name for p in written + drawn] + [n for n in planned if n.endswith(".meta.json")]
        _write_manifest(out, [n for n in dict.fromkeys(names) if os.path.lexists(out / n)], complete=True,
                        partial=partial)
        if failed is not None:
            raise PictureError(failed, written + drawn) from failed
    except PictureError:
        raise
    except BaseException as exc:
        if pictures is not None:
            pictures.close()  # stopped (its write in progress removed) before the files go
            # one deaf to the polite signal was killed outright in the middle of an atomic
            # write: its temporary file is the only trace (the folder is this run's alone)
            remove_stale_temps(out)
        _remove(out, planned + [p.name for p in drawn] + [MANIFEST])
        if isinstance(exc, OSError):
            raise WriteError(exc.errno, f"{exc}; none of the run's files were kept in {out}") from exc
        raise
    return written + sorted(drawn, key=lambda p: RUN_FILES.index(p.name) if p.name in RUN_FILES else len(RUN_FILES))


# what each picture costs to draw, about, against a paths picture (formation_army: paths
# 0.21 s, values 0.24 s, snapshots figure 0.4 s, its GIF 1.1 s, player 0.07 s)
PICTURE_COST = {"snapshots": 7.0, "snapshots-animation": 5.0, "snapshots-figure": 2.0, "player": 0.5}


def picture_parts(plots: list[str], parts: int, split: dict | None = None) -> list[list[str]]:
    """``plots`` in up to ``parts`` lists of about equal drawing time (the longest
    first, each to the lightest list so far), in their given order within a list.
    ``split``: names that stand for pictures drawable apart (a method's
    ``PICTURE_PARTS``), replaced by those."""
    names = [part for n in plots for part in (split or {}).get(n, (n,))]
    lists: list[list[str]] = [[] for _ in range(max(1, min(parts, len(names))))]
    load = [0.0] * len(lists)
    for name in sorted(names, key=lambda n: -PICTURE_COST.get(n, 1.0)):
        k = load.index(min(load))
        lists[k].append(name)
        load[k] += PICTURE_COST.get(name, 1.0)
    return [[n for n in names if n in part] for part in lists if part]


def draw_pictures(method: str, scene, extras, trajectories, out: Path, plots: list[str], title: str) -> list[Path]:
    """The pictures named in ``plots`` (the method's figures, and ``player`` for
    view.html) of one run, written into ``out``; returns their paths."""
    written = []
    module = get_method(method).module
    pictures = [p for p in plots if p != "player"]
    if pictures and hasattr(module, "write_plots"):
        written += module.write_plots(scene, extras, out, pictures, title)
    if "player" in plots:
        from crowdmotion.render.player import write_player

        written.append(write_player(trajectories, out / "view.html"))
    return written
