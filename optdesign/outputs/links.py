"""Following the links of an output path as the kernel's ``fs.protected_symlinks`` does,
whatever the machine's setting.

An output folder is often made in a shared folder (``/tmp``, a team's sticky ``results/``).
Another user may plant a link there at the name the run is about to write (its own folder,
or ``results`` itself), pointing at a folder of the runner's or of a third user's: followed,
the run replaces that folder's files. Linux refuses to follow such a link when
``fs.protected_symlinks=1``; a machine with 0 (or another system) does not, so the tool
applies the same rule itself, to every link on the way to the output folder.

The rule (``may_follow_link`` in the kernel's ``fs/namei.c``): a link is followed when

* it belongs to the user running the command, or
* the folder holding it is not both sticky and world-writable (only its owner, or users it
  trusts, could have put it there), or
* it belongs to the owner of that folder (who controls the folder's names anyway).

So ``--out`` through a link of one's own keeps working; a stranger's link in ``/tmp`` does not.
"""
from __future__ import annotations

import os
import stat

from optdesign.errors import UsageError

#: most links followed on one path (the kernel's MAXSYMLINKS)
MAX_LINKS = 40
_SHARED = stat.S_ISVTX | stat.S_IWOTH


def may_follow(link: os.stat_result, folder: os.stat_result) -> bool:
    """The kernel's protected-symlinks rule: may this process follow ``link`` (its
    ``lstat``), found in ``folder`` (the ``stat`` of the folder holding it)?"""
    return (link.st_uid == os.geteuid() or folder.st_mode & _SHARED != _SHARED
            or link.st_uid == folder.st_uid)


def followed(path, label: str) -> str:
    """The real path of ``path`` (as :func:`os.path.realpath` gives it: every link followed,
    ``..`` taken after the link before it, missing components kept as named), refusing with
    :class:`UsageError` a link :func:`may_follow` refuses. ``label`` names the path in the
    message (``--out x`` or the default folder)."""
    text = os.fspath(path)
    here = "/" if text.startswith("/") else os.getcwd()
    todo = list(reversed(text.split("/")))
    links = 0
    while todo:
        part = todo.pop()
        if part in ("", "."):
            continue
        if part == "..":
            here = os.path.dirname(here)
            continue
        step = os.path.join(here, part)
        try:
            st = os.lstat(step)
        except OSError:             # not there (yet): the run makes it, nothing to follow
            here = step
            continue
        if not stat.S_ISLNK(st.st_mode):
            here = step
            continue
        links += 1
        if links > MAX_LINKS:
            raise UsageError(f"{label}: {step} leads through more than {MAX_LINKS} links")
        folder = os.stat(here)
        if not may_follow(st, folder):
            raise UsageError(
                f"{label}: {step} is a link of another user (uid {st.st_uid}) in the shared "
                f"folder {here} (sticky and world-writable); it is not followed: remove it or "
                f"choose another --out")
        target = os.readlink(step)
        if target.startswith("/"):
            here = "/"
        todo.extend(reversed(target.split("/")))
    return here
