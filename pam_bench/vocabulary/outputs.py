"""The one rule for what a verb may write, and where.

A verb writes only into a new folder, or into a folder it created itself: such a folder holds a
marker, ``MARKER`` (which verb made it, and the files it wrote once it finished). It replaces
such a folder only when asked (``--overwrite``) and only after every check that can run before
writing has passed; it deletes only the files the marker lists, and refuses when the folder
holds any other. It never writes into a bag folder (a folder with ``metadata.yaml`` or
``.mcap`` files, or anything inside one), nor over its own inputs. ``bag-repair`` is the one
verb that changes a bag, and it keeps what it replaces.

Three ways to write, one check behind them (``check_output``):

- ``staged_output``: the verb writes into a hidden sibling folder, which takes the target's
  place only once complete (extract, comparisons, plots); an interrupted verb leaves the old
  output as it was.
- ``claim_output`` / ``seal_output``: the verb writes in place (a recorder filling a bag, a
  sweep that a rerun continues); the marker says "in progress" until sealed.
- ``check_output_file`` / ``write_output_file``: one file (an overlay), marked by its first
  line.

An existing empty folder counts as new (a user's ``mkdir``); a legacy bag of pam_bench (a
``metadata.yaml`` whose custom data holds ``pam_bench.run``, from before markers) counts as
the recorder's own, with the files its metadata lists.

The rule acts on the resolved path: an ``--out`` that is a symbolic link names the folder it
points to, which is checked, cleared and written as if named directly (``check_output``
returns it; the other functions resolve what they are given). ``--overwrite`` replaces only an
output of the same verb (a bag of a recorder for ``run``), never another verb's. A path that
is empty, or whose name or whole is longer than the file system takes, is refused in one line.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import pathlib
import shutil
import tempfile
from collections.abc import Iterable, Iterator

from pam_bench.vocabulary.errors import OutputError, quoted

__all__ = ['MARKER', 'FILE_MARK', 'BAG_VERBS', 'resolved', 'is_bag_folder', 'own_files',
           'check_output', 'clear_output', 'claim_output', 'seal_output', 'note_output_file',
           'staged_output', 'check_output_file', 'write_output_file']

MARKER = '.pam_bench_output.json'
"""The file that marks a folder as written by pam_bench: ``{"verb", "created", "files",
"bag"}`` (``files`` null while the verb is still writing, or was killed while it did)."""
FILE_MARK = '# written by pam-bench '
"""The first line of a one-file output (an overlay): marks it as pam_bench's own."""
_LEGACY_BAG_EXTRA = ('wall_stats.json',)


def is_bag_folder(path: pathlib.Path) -> bool:
    """Whether ``path`` is a rosbag2 folder: it holds a ``metadata.yaml``, or a bag being
    written (the recorder's part folders), or its marker says a recorder made it."""
    if not path.is_dir():
        return False
    if (path / 'metadata.yaml').exists():
        return True
    marker = _read_marker(path)
    if marker is not None and marker.get('bag'):
        return True
    try:
        return any(p.name.startswith('.part_') for p in path.iterdir())
    except OSError:
        return False


def _read_marker(path: pathlib.Path) -> dict[str, object] | None:
    try:
        data = json.loads((path / MARKER).read_text(encoding='utf-8'))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _legacy_bag_files(path: pathlib.Path) -> set[str] | None:
    """The files of a bag pam_bench recorded before markers existed, else None."""
    meta = path / 'metadata.yaml'
    try:
        if meta.stat().st_size > 1 << 20:
            return None
        text = meta.read_text(encoding='utf-8')
    except (OSError, UnicodeDecodeError):
        return None
    if 'pam_bench.run' not in text:
        return None
    import yaml

    from pam_bench.vocabulary.yaml_io import load_written
    try:
        info = (load_written(text) or {}).get('rosbag2_bagfile_information', {})
        names = [str(n) for n in info.get('relative_file_paths') or []]
    except (yaml.YAMLError, AttributeError):
        return None
    return {'metadata.yaml', *names, *_LEGACY_BAG_EXTRA}


def own_files(path: pathlib.Path) -> tuple[str, set[str] | None] | None:
    """Who made the folder ``path`` and which files it wrote (None: still writing or killed,
    so everything in it), or None when pam_bench did not make it."""
    marker = _read_marker(path)
    if marker is not None:
        files = marker.get('files')
        return (str(marker.get('verb', '?')),
                None if files is None else {str(f) for f in files}    # type: ignore[attr-defined]
                )
    legacy = _legacy_bag_files(path)
    return ('pam-bench run', legacy) if legacy is not None else None


def _contents(path: pathlib.Path) -> list[str]:
    """Every file below ``path`` (relative, folders as their files), the marker left out."""
    out = []
    for root, _, files in os.walk(path):
        for f in files:
            rel = os.path.relpath(os.path.join(root, f), path)
            if rel != MARKER:
                out.append(rel)
    return sorted(out)


def _inside(a: pathlib.Path, b: pathlib.Path) -> bool:
    """Whether ``a`` is ``b`` or lies below it (both resolved)."""
    return a == b or b in a.parents


BAG_VERBS = ('pam-bench record', 'pam-bench run')
"""Verbs whose output is a bag: ``run --overwrite`` may replace the bag of either."""


def resolved(path: str | pathlib.Path, what: str = '--out') -> pathlib.Path:
    """``path`` with ``~`` expanded and symbolic links resolved, checked to be one the file
    system can hold.

    Raises:
        OutputError: empty, or a name or the whole longer than the file system takes.
    """
    text = str(path)
    if not text.strip():
        raise OutputError(f'{what} is empty: name a folder or file')
    out = pathlib.Path(text).expanduser()
    name_max, path_max = 255, 4096
    with contextlib.suppress(OSError, ValueError):
        anchor = next((p for p in (out, *out.parents) if p.exists()), pathlib.Path('.'))
        name_max = os.pathconf(anchor, 'PC_NAME_MAX')
        path_max = os.pathconf(anchor, 'PC_PATH_MAX')
    long = [part for part in out.parts if len(part.encode()) > name_max]
    if long:
        raise OutputError(f'{what} {quoted(text)}: the name {quoted(long[0], 40)} has '
                          f'{len(long[0].encode())} bytes, over the {name_max} the file '
                          'system takes')
    try:
        out = out.resolve()
    except (OSError, RuntimeError) as exc:        # a symlink loop
        raise OutputError(f'{what} {quoted(text)}: cannot resolve it: {exc}') from None
    if len(str(out).encode()) >= path_max:
        raise OutputError(f'{what} {quoted(text)}: {len(str(out).encode())} bytes resolved, '
                          f'over the {path_max} the file system takes')
    return out


def check_output(path: str | pathlib.Path, verb: str, overwrite: bool,
                 inputs: Iterable[str | pathlib.Path] = (), bag: bool = False) -> pathlib.Path:
    """Check, writing nothing, that ``verb`` may write the folder ``path``.

    Args:
        path: the output folder.
        verb: who writes (``'pam-bench extract'``), for the marker and the messages.
        overwrite: the user asked to replace an existing output of pam_bench.
        inputs: paths the verb reads (bags, files): the output may not hold any of them nor
            lie inside one.
        bag: the verb records a bag into ``path`` (then a bag folder of pam_bench's own may
            be replaced; other verbs never write into a bag folder).

    Returns:
        ``path`` resolved.

    Raises:
        OutputError: the verb may not write there; the message says why and what to do.
    """
    out = resolved(path)
    shown = str(path) if pathlib.Path(path) == out else f'{path} (-> {out})'
    for given in inputs:
        src = pathlib.Path(given).expanduser().resolve()
        if _inside(src, out) or _inside(out, src):
            raise OutputError(f'{shown}: the output would hold or replace the input {given}; '
                              'pick another --out')
    for parent in out.parents:
        if is_bag_folder(parent):
            raise OutputError(f'{shown}: inside the bag folder {parent}; pam-bench does not '
                              'write into bags: pick an --out outside it')
    if out.exists() and not out.is_dir():
        raise OutputError(f'{shown} is a file, not a folder; pick another --out')
    if not out.exists():
        return out
    try:
        contents = _contents(out)
    except OSError as exc:
        raise OutputError(f'{shown}: cannot list it: {exc.strerror}') from None
    own = own_files(out)
    if not contents and own is None:
        return out                                   # an empty folder: as good as new
    if is_bag_folder(out) and not bag:
        raise OutputError(f'{shown} is a bag folder; pam-bench does not write into bags: pick '
                          'another --out')
    if own is None:
        raise OutputError(f'{shown} exists and was not written by pam-bench; pick a new or '
                          'empty folder (nothing in it is deleted)')
    if not overwrite:
        raise OutputError(f'{shown} exists (written by {own[0]}): add --overwrite to replace '
                          'it, or pick another --out')
    if own[0] != verb and not (bag and own[0] in BAG_VERBS):
        raise OutputError(f'{shown} holds the output of {own[0]}, not of {verb}: --overwrite '
                          f'replaces only what {verb} wrote; pick another --out')
    files = own[1]
    foreign = [f for f in contents if files is not None and f not in files]
    if foreign:
        raise OutputError(f'{shown} holds {len(foreign)} file(s) pam-bench did not write '
                          f'({foreign[0]}{", ..." if len(foreign) > 1 else ""}): move them '
                          'out or pick another --out')
    return out


def clear_output(path: pathlib.Path) -> None:
    """Delete what pam_bench wrote in the folder ``path`` (checked by ``check_output``), then
    the folder when nothing else is left in it."""
    path = pathlib.Path(path).resolve()
    own = own_files(path)
    if own is None:
        if path.exists() and not any(path.iterdir()):
            path.rmdir()
        return
    files = own[1]
    for rel in _contents(path):
        if files is None or rel in files:
            (path / rel).unlink()
    (path / MARKER).unlink(missing_ok=True)
    for root, dirs, _ in sorted(os.walk(path, topdown=False), key=lambda t: -len(t[0])):
        for d in dirs:
            with contextlib.suppress(OSError):           # not empty: a file it kept
                os.rmdir(os.path.join(root, d))
    with contextlib.suppress(OSError):
        path.rmdir()


def _write_marker(path: pathlib.Path, verb: str, files: list[str] | None,
                  bag: bool = False) -> None:
    old = _read_marker(path) or {}
    data = {'verb': verb, 'created': str(old.get('created') or datetime.datetime.now(
        datetime.UTC).isoformat(timespec='seconds')), 'files': files,
        'bag': bool(old.get('bag')) or bag}
    tmp = path / (MARKER + '.tmp')
    tmp.write_text(json.dumps(data), encoding='utf-8')
    tmp.replace(path / MARKER)


def claim_output(path: str | pathlib.Path, verb: str, bag: bool = False) -> pathlib.Path:
    """Create the folder ``path`` (or take an empty one) and mark it as ``verb``'s, in
    progress (``bag``: a recorder's bag). ``check_output`` (and ``clear_output`` for a
    replacement) come first.

    Raises:
        OutputError: the folder holds files already, or cannot be created.
    """
    out = resolved(path)
    try:
        out.mkdir(parents=True, exist_ok=True)
        if _contents(out) and own_files(out) is None:
            raise OutputError(f'{path} is not empty; pick a new folder')
        _write_marker(out, verb, None, bag)
    except OSError as exc:
        if isinstance(exc, OutputError):
            raise
        raise OutputError(f'{path}: cannot create it: {exc.strerror or exc}') from None
    return out


def seal_output(path: str | pathlib.Path, verb: str | None = None) -> None:
    """Mark the folder ``path`` complete: its marker lists every file in it (``verb``: who
    wrote it; None keeps the marker's)."""
    out = pathlib.Path(path)
    if verb is None:
        verb = str((_read_marker(out) or {}).get('verb') or 'pam-bench')
    _write_marker(out, verb, _contents(out))


def note_output_file(path: str | pathlib.Path, name: str) -> None:
    """Add the file ``name`` that pam_bench wrote into its own folder ``path`` to the folder's
    marker (a sealed bag's ``wall_stats.json``); nothing when the marker is not complete."""
    out = pathlib.Path(path)
    marker = _read_marker(out)
    files = marker.get('files') if marker is not None else None
    if isinstance(files, list) and name not in files:
        _write_marker(out, str(marker.get('verb')) if marker else 'pam-bench',
                      sorted([*files, name]))


@contextlib.contextmanager
def staged_output(path: str | pathlib.Path, verb: str, overwrite: bool,
                  inputs: Iterable[str | pathlib.Path] = ()) -> Iterator[pathlib.Path]:
    """A hidden folder beside ``path`` to write into; once the block ends without an error it
    is sealed and takes the place of ``path`` (an old output of pam_bench, ``--overwrite``).

    Raises:
        OutputError: ``check_output`` refuses ``path`` (before anything is written).
    """
    out = check_output(path, verb, overwrite, inputs)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = pathlib.Path(tempfile.mkdtemp(prefix=f'.{out.name}.', dir=out.parent))
    except OSError as exc:
        raise OutputError(f'{path}: cannot write beside it: {exc.strerror or exc}') from None
    try:
        yield tmp
        seal_output(tmp, verb)
        check_output(path, verb, overwrite, inputs)     # still ours (nothing came in since)
        if out.exists():
            clear_output(out)
        if out.exists():                  # an empty folder the user made, or one kept
            out.rmdir()
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def check_output_file(path: str | pathlib.Path, verb: str, overwrite: bool,
                      inputs: Iterable[str | pathlib.Path] = ()) -> pathlib.Path:
    """Check, writing nothing, that ``verb`` may write the file ``path``: a new file, or one
    pam_bench wrote (its first line is ``FILE_MARK``) with ``overwrite``; never inside a bag
    folder, never over an input.

    Raises:
        OutputError: it may not (the message says why).
    """
    out = resolved(path)
    for given in inputs:
        src = pathlib.Path(given).expanduser().resolve()
        if _inside(out, src) or out == src:
            raise OutputError(f'{path}: the output would replace or sit inside the input '
                              f'{given}; pick another --out')
    for parent in out.parents:
        if is_bag_folder(parent):
            raise OutputError(f'{path}: inside the bag folder {parent}; pam-bench does not '
                              'write into bags')
    if out.is_dir():
        raise OutputError(f'{path} is a folder; name a file')
    if out.exists():
        try:
            with open(out, encoding='utf-8', errors='replace') as fh:
                first = fh.readline(200)
        except OSError as exc:
            raise OutputError(f'{path}: cannot read it: {exc.strerror}') from None
        if not first.startswith((FILE_MARK, '# pam-bench ')):   # and overlays of before
            raise OutputError(f'{path} exists and was not written by pam-bench; pick another '
                              'name')
        if not overwrite:
            raise OutputError(f'{path} exists: add --overwrite to replace it')
        writer = first[len(FILE_MARK):].strip() if first.startswith(FILE_MARK) else verb
        if writer != verb:
            raise OutputError(f'{path} was written by {writer}, not by {verb}: --overwrite '
                              f'replaces only what {verb} wrote; pick another name')
    return out


def write_output_file(path: str | pathlib.Path, verb: str, text: str) -> None:
    """Write ``text`` to the file ``path`` (checked by ``check_output_file``) after its
    marking first line, atomically (a temporary file beside it, then renamed)."""
    out = resolved(path)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_name(f'.{out.name}.tmp')
        tmp.write_text(f'{FILE_MARK}{verb}\n{text}', encoding='utf-8')
        tmp.replace(out)
    except OSError as exc:
        raise OutputError(f'{path}: cannot write it: {exc.strerror or exc}') from None
