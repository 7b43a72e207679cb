"""``cell snapshot``'s output folder, written whole or not at all.

:func:`check_out` checks the folder ``--out`` names before the run; an :class:`OutputSet`
stages the files in a new folder beside it (``OUT.tmp-XXXXXXXX``), every write checked,
and swaps it into place on :meth:`OutputSet.commit` (the old folder renamed aside to
``OUT.old-XXXXXXXX``, the new one renamed to ``OUT``, the old one removed), or removes
the staging folder and the parents it made on :meth:`OutputSet.discard`. An existing
``OUT`` is replaced only when it holds nothing but snapshot outputs (:data:`OUTPUTS`).
"""

from __future__ import annotations

import os
import secrets
import shutil
import stat
import sys
from collections.abc import Callable
from pathlib import Path

import cv2

from cell.errors import JobError
from cell.files import signals_held
from cell.text import escape

__all__ = ["OUTPUTS", "OutputSet", "check_out"]

OUTPUTS = ("rgb.png", "depth.npy", "seg.npy", "camera.json", "truth.json", "cell.xml")
"""Every file a snapshot may write: the only entries an existing ``--out`` folder may hold."""


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def check_out(arg: str) -> Path:
    """The folder ``--out`` names, resolved; a ``JobError`` if it cannot take a snapshot.

    Checked before the run so a bad path fails at once: not empty, not the current folder
    (or one above it), an existing entry must be a folder holding only snapshot outputs,
    and the nearest existing ancestor must be a folder that can be written.
    """
    shown = f"--out {arg!r}"
    if not arg:
        raise JobError(f"{shown}: empty path; name the output folder")
    try:
        cwd = Path.cwd()
        target = Path(os.path.abspath(arg))
        resolved = target.resolve()  # follow links: the folder a link points to is the one replaced
        for path in (target, resolved):
            if path == cwd or path in cwd.parents:
                raise JobError(f"{shown}: is the current folder or holds it; name a folder inside it")
        target = probe = resolved
        while True:
            try:
                st = probe.stat()
                break
            except FileNotFoundError:
                probe = probe.parent
    except OSError as exc:  # a name too long, a loop of links, no permission to look
        raise JobError(f"{shown}: cannot be used: {_reason(exc)}") from None
    except (RuntimeError, ValueError) as exc:  # a loop of links (Python < 3.13), a NUL character
        raise JobError(f"{shown}: cannot be used: {exc}") from None
    if not stat.S_ISDIR(st.st_mode):
        if probe == target:
            raise JobError(f"{shown}: exists and is not a folder")
        raise JobError(f"{shown}: cannot be created: {str(probe)!r} is not a folder")
    if probe == target:
        if target == Path(target.anchor):
            raise JobError(f"{shown}: is a file system root; name a folder inside it")
        try:
            foreign = sorted(name for name in os.listdir(target) if name not in OUTPUTS)
        except OSError as exc:
            raise JobError(f"{shown}: cannot be read: {_reason(exc)}") from None
        if foreign:
            listed = ", ".join(repr(n) for n in foreign[:3]) + (", ..." if len(foreign) > 3 else "")
            raise JobError(f"{shown}: holds entries that are not snapshot outputs ({listed}); "
                            "name a new folder, or one written only by cell snapshot")
        need = [target, target.parent]
    else:
        need = [probe]
    for folder in need:
        if not os.access(folder, os.W_OK | os.X_OK):
            raise JobError(f"{shown}: cannot be written: no write permission in {str(folder)!r}")
    return target


class OutputSet:
    """An output folder staged beside ``target`` and swapped into place on :meth:`commit`."""

    def __init__(self, arg: str, target: Path) -> None:
        self.arg, self.target = arg, target
        self.created: list[Path] = []  # parent folders this run made, outermost first
        self.staging: Path | None = None
        self.written: list[str] = []
        try:
            missing = []
            parent = target.parent
            while not parent.exists():
                missing.append(parent)
                parent = parent.parent
            for folder in reversed(missing):
                folder.mkdir()
                self.created.append(folder)
            self.staging = self._new_folder("tmp")
        except OSError as exc:
            self.discard()
            raise JobError(f"--out {arg!r}: cannot be created: {_reason(exc)}") from None

    def _new_folder(self, tag: str) -> Path:
        """A new empty folder ``<target name>.<tag>-XXXXXXXX`` beside the target."""
        stem = self.target.name[:200]
        while True:
            folder = self.target.parent / f"{stem}.{tag}-{secrets.token_hex(4)}"
            try:
                folder.mkdir()
                return folder
            except FileExistsError:
                continue

    def write(self, name: str, writer: Callable[[Path], object]) -> None:
        """Run ``writer(path)`` for ``name`` in the staging folder; any failure is a ``JobError``.

        A writer that returns ``False`` (as an image encoder does) has failed.
        """
        shown = repr(str(self.target / name))
        try:
            ok = writer(self.staging / name)
        except OSError as exc:
            raise JobError(f"cannot write {shown}: {_reason(exc)}") from None
        except ValueError as exc:  # json.dumps(allow_nan=False) and friends
            raise JobError(f"cannot write {shown}: {exc}") from None
        except cv2.error as exc:
            raise JobError(f"cannot write {shown}: OpenCV: {str(exc).strip().splitlines()[-1]}") from None
        if ok is False:
            raise JobError(f"cannot write {shown}: the image encoder failed")
        self.written.append(name)

    def commit(self) -> None:
        """Swap the staged set into place; the earlier folder, if any, is removed after.
        Ctrl-C and SIGTERM are held off meanwhile (:func:`cell.files.signals_held`): the
        swap happens whole, the earlier folder gone, before one takes effect."""
        with signals_held():
            self._swap()

    def _swap(self) -> None:
        """:meth:`commit`, its signals held."""
        target, aside = self.target, None
        check_out(self.arg)  # again: the folder may have changed while the world ran
        try:
            if os.path.lexists(target):
                aside = self._new_folder("old")
                os.rename(target, aside)  # replaces the empty placeholder atomically
            try:
                os.rename(self.staging, target)
            except OSError as exc:
                if aside is not None:
                    try:
                        os.rename(aside, target)
                    except OSError:
                        raise JobError(f"--out {self.arg!r}: cannot be replaced: {_reason(exc)}; "
                                        f"the earlier output is now in {str(aside)!r}") from None
                    aside = None
                raise
        except OSError as exc:
            if aside is not None and aside.exists() and not any(aside.iterdir()):
                aside.rmdir()
            raise JobError(f"--out {self.arg!r}: cannot be replaced: {_reason(exc)}") from None
        self.staging, self.created = None, []
        if aside is not None:
            shutil.rmtree(aside, ignore_errors=True)
            if aside.exists():
                print(f"cell snapshot: warning: could not remove the earlier output "
                      f"{escape(repr(str(aside)))}", file=sys.stderr)

    def discard(self) -> None:
        """Remove the staging folder and the parents this run created (the run failed)."""
        if self.staging is not None:
            shutil.rmtree(self.staging, ignore_errors=True)
            self.staging = None
        for folder in reversed(self.created):
            try:
                folder.rmdir()
            except OSError:
                break
        self.created = []
