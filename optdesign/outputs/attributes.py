"""What a folder is besides its files: owner, group, mode and extended attributes.

``solve`` puts its set in place by exchanging the output folder with a fresh sibling
(:mod:`optdesign.outputs.folder`). The sibling is the runner's, with the runner's group and
umask; a team's folder (group ``team``, mode 2770, an ACL or a ``user.*`` attribute of a
backup tool) would come back as the runner's own and the team would lose it. So the sibling
takes on the folder's attributes first, and when one cannot be given (another user's folder
for a runner who is not root, a group the runner is not in, an attribute the file system
refuses) the caller writes into the existing folder instead (:func:`take_on` says which).
"""
from __future__ import annotations

import errno
import os
import stat

#: extended attributes that are not the folder's to copy: the security module labels each
#: new folder itself (SELinux, Smack) and capabilities belong to files
_NOT_COPIED = ("security.",)


def take_on(folder, staging) -> bool:
    """Give ``staging`` the owner, group, mode (setgid and sticky bits included) and extended
    attributes of ``folder``; True when it now has every one of them, False when one could
    not be given (``staging`` is then to be written into ``folder``, not exchanged with it)."""
    try:
        st = os.stat(folder)
        if (st.st_uid, st.st_gid) != _owner(staging):
            os.chown(staging, st.st_uid, st.st_gid)     # before the mode: chown may clear setgid
        os.chmod(staging, stat.S_IMODE(st.st_mode))
        _copy_xattrs(folder, staging)
    except OSError:
        return False
    return same_attributes(folder, staging)


def same_attributes(a, b) -> bool:
    """True when the folders ``a`` and ``b`` have one owner, group, mode and set of
    extended attributes (those :func:`take_on` copies)."""
    try:
        sa, sb = os.stat(a), os.stat(b)
        return ((sa.st_uid, sa.st_gid, stat.S_IMODE(sa.st_mode))
                == (sb.st_uid, sb.st_gid, stat.S_IMODE(sb.st_mode))
                and _xattrs(a) == _xattrs(b))
    except OSError:
        return False


def _owner(path) -> tuple[int, int]:
    st = os.stat(path)
    return st.st_uid, st.st_gid


def _xattrs(path) -> dict[str, bytes]:
    """The copied extended attributes of ``path`` (none where the platform has none)."""
    if not hasattr(os, "listxattr"):
        return {}
    try:
        names = os.listxattr(path)
    except OSError as exc:
        if exc.errno in (errno.ENOTSUP, errno.EOPNOTSUPP):     # a file system without them
            return {}
        raise
    return {n: os.getxattr(path, n) for n in names if not n.startswith(_NOT_COPIED)}


def _copy_xattrs(source, target) -> None:
    have = _xattrs(target)
    want = _xattrs(source)
    for name in have.keys() - want.keys():
        os.removexattr(target, name)
    for name, value in want.items():
        if have.get(name) != value:
            os.setxattr(target, name, value)
