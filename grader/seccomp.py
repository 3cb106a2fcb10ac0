"""A seccomp filter that shuts the kernel's doors a graded submission has no business opening.

Installed in every submission's process just before its code runs (:mod:`grader.zygote`),
after it has dropped to its own user id. It refuses, with ``EPERM``:

* new namespaces of any kind (``unshare``, ``setns``, ``clone`` with a ``CLONE_NEW*`` flag;
  ``clone3``, whose flags a filter cannot read, answers ``ENOSYS`` so that the C library falls
  back to ``clone``), and every way to mount, move or re-root a file system — so a submission
  cannot build itself a user namespace in which it is root and ``mount`` becomes possible;
* ``ptrace`` and reading or writing another process's memory;
* raising its own resource limits (``setrlimit``, and ``prlimit64`` with a new limit; reading
  them stays allowed), so its time, memory and process limits stay the grader's;
* ``SIGKILL`` from inside (``kill``, ``tkill``, ``tgkill``, the ``sigqueue`` calls,
  ``pidfd_send_signal``): a submission's process that dies by ``SIGKILL`` was killed by its
  limits, the grader or someone outside — never by itself, which is how the grader tells an
  honest student's sandbox killed from outside (retried) from a submission's own doing;
* loading kernel modules or BPF programs, ``perf_event_open``, ``userfaultfd``, keyrings,
  ``io_uring``, file handles by number.

Standard library only: the sandbox imports it by path before anything of the kit. The filter
is written for x86-64 and AArch64; on another architecture :func:`install` returns ``False``
and the grader says so.
"""

from __future__ import annotations

import ctypes
import errno
import platform
import struct

__all__ = ["ARCHES", "install", "program"]

PR_SET_NO_NEW_PRIVS = 38
PR_SET_SECCOMP = 22
SECCOMP_MODE_FILTER = 2

# classic BPF
LD_W_ABS = 0x20       # BPF_LD | BPF_W | BPF_ABS
JEQ_K = 0x15          # BPF_JMP | BPF_JEQ | BPF_K
JGE_K = 0x35          # BPF_JMP | BPF_JGE | BPF_K
JSET_K = 0x45         # BPF_JMP | BPF_JSET | BPF_K
RET_K = 0x06          # BPF_RET | BPF_K

RET_ALLOW = 0x7FFF0000
RET_ERRNO = 0x00050000

# offsets in struct seccomp_data
NR, ARCH = 0, 4


def _arg_low(i: int) -> int:
    return 16 + 8 * i  # little-endian: the low 32 bits first


def _arg_high(i: int) -> int:
    return 16 + 8 * i + 4


CLONE_NEW_FLAGS = (0x00020000 | 0x02000000 | 0x04000000 | 0x08000000 | 0x10000000
                   | 0x20000000 | 0x40000000 | 0x00000080)
"""CLONE_NEWNS, NEWCGROUP, NEWUTS, NEWIPC, NEWUSER, NEWPID, NEWNET, NEWTIME."""
SIGKILL = 9

DENIED = ("mount", "umount2", "pivot_root", "chroot", "unshare", "setns", "open_tree",
          "move_mount", "fsopen", "fsconfig", "fsmount", "fspick", "mount_setattr", "ptrace",
          "process_vm_readv", "process_vm_writev", "kexec_load", "kexec_file_load",
          "init_module", "finit_module", "delete_module", "bpf", "perf_event_open",
          "userfaultfd", "keyctl", "add_key", "request_key", "open_by_handle_at",
          "name_to_handle_at", "setrlimit", "io_uring_setup", "io_uring_enter",
          "io_uring_register")
SIGNAL_ARG = {"kill": 1, "tkill": 1, "tgkill": 2, "rt_sigqueueinfo": 1,
              "rt_tgsigqueueinfo": 2, "pidfd_send_signal": 1}
"""which argument holds the signal number."""

ARCHES: dict[str, tuple[int, dict[str, int]]] = {
    "x86_64": (0xC000003E, {
        "mount": 165, "umount2": 166, "pivot_root": 155, "chroot": 161, "unshare": 272,
        "setns": 308, "open_tree": 428, "move_mount": 429, "fsopen": 430, "fsconfig": 431,
        "fsmount": 432, "fspick": 433, "mount_setattr": 442, "ptrace": 101,
        "process_vm_readv": 310, "process_vm_writev": 311, "kexec_load": 246,
        "kexec_file_load": 320, "init_module": 175, "finit_module": 313, "delete_module": 176,
        "bpf": 321, "perf_event_open": 298, "userfaultfd": 323, "keyctl": 250, "add_key": 248,
        "request_key": 249, "open_by_handle_at": 304, "name_to_handle_at": 303,
        "setrlimit": 160, "prlimit64": 302, "io_uring_setup": 425, "io_uring_enter": 426,
        "io_uring_register": 427, "clone": 56, "clone3": 435, "kill": 62, "tkill": 200,
        "tgkill": 234, "rt_sigqueueinfo": 129, "rt_tgsigqueueinfo": 297,
        "pidfd_send_signal": 424}),
    "aarch64": (0xC00000B7, {
        "mount": 40, "umount2": 39, "pivot_root": 41, "chroot": 51, "unshare": 97,
        "setns": 268, "open_tree": 428, "move_mount": 429, "fsopen": 430, "fsconfig": 431,
        "fsmount": 432, "fspick": 433, "mount_setattr": 442, "ptrace": 117,
        "process_vm_readv": 270, "process_vm_writev": 271, "kexec_load": 104,
        "kexec_file_load": 294, "init_module": 105, "finit_module": 273, "delete_module": 106,
        "bpf": 280, "perf_event_open": 241, "userfaultfd": 282, "keyctl": 219, "add_key": 217,
        "request_key": 218, "open_by_handle_at": 265, "name_to_handle_at": 264,
        "setrlimit": 164, "prlimit64": 261, "io_uring_setup": 425, "io_uring_enter": 426,
        "io_uring_register": 427, "clone": 220, "clone3": 435, "kill": 129, "tkill": 130,
        "tgkill": 131, "rt_sigqueueinfo": 138, "rt_tgsigqueueinfo": 240,
        "pidfd_send_signal": 424}),
}


def _stmt(code: int, k: int, jt: int = 0, jf: int = 0) -> tuple[int, int, int, int]:
    return code, jt, jf, k


def program(machine: str) -> list[tuple[int, int, int, int]]:
    """The filter for ``machine`` (``platform.machine()``), as (code, jt, jf, k) steps."""
    audit_arch, numbers = ARCHES[machine]
    deny = RET_ERRNO | errno.EPERM
    steps = [_stmt(LD_W_ABS, ARCH),
             _stmt(JEQ_K, audit_arch, jt=1),        # another ABI (32-bit calls): refuse all
             _stmt(RET_K, deny),
             _stmt(LD_W_ABS, NR)]
    if machine == "x86_64":                        # the x32 ABI's numbers
        steps += [_stmt(JGE_K, 0x40000000, jf=1), _stmt(RET_K, deny)]
    for name in DENIED:
        steps += [_stmt(JEQ_K, numbers[name], jf=1), _stmt(RET_K, deny)]
    steps += [_stmt(JEQ_K, numbers["clone3"], jf=1), _stmt(RET_K, RET_ERRNO | errno.ENOSYS)]
    # clone with a new namespace's flag
    steps += [_stmt(JEQ_K, numbers["clone"], jf=4), _stmt(LD_W_ABS, _arg_low(0)),
              _stmt(JSET_K, CLONE_NEW_FLAGS, jf=1), _stmt(RET_K, deny),
              _stmt(RET_K, RET_ALLOW)]
    # prlimit64(pid, resource, new, old): allowed only with new == NULL
    steps += [_stmt(JEQ_K, numbers["prlimit64"], jf=6), _stmt(LD_W_ABS, _arg_low(2)),
              _stmt(JEQ_K, 0, jf=3), _stmt(LD_W_ABS, _arg_high(2)), _stmt(JEQ_K, 0, jf=1),
              _stmt(RET_K, RET_ALLOW), _stmt(RET_K, deny)]
    for name, arg in SIGNAL_ARG.items():
        steps += [_stmt(JEQ_K, numbers[name], jf=4), _stmt(LD_W_ABS, _arg_low(arg)),
                  _stmt(JEQ_K, SIGKILL, jf=1), _stmt(RET_K, deny), _stmt(RET_K, RET_ALLOW)]
    steps.append(_stmt(RET_K, RET_ALLOW))
    return steps


class _SockFprog(ctypes.Structure):
    _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]


def install() -> bool:
    """Load the filter into this process (and everything it starts from now on). Sets
    ``no_new_privs`` first, as the kernel requires. ``False`` on an architecture it does not
    know; ``OSError`` if the kernel refuses it."""
    machine = platform.machine()
    if machine not in ARCHES:
        return False
    steps = program(machine)
    blob = b"".join(struct.pack("=HBBI", code, jt, jf, k) for code, jt, jf, k in steps)
    buffer = ctypes.create_string_buffer(blob, len(blob))
    prog = _SockFprog(len(steps), ctypes.cast(buffer, ctypes.c_void_p))
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_void_p, ctypes.c_ulong,
                           ctypes.c_ulong]
    if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, None, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_NO_NEW_PRIVS)")
    if libc.prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, ctypes.addressof(prog), 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_SECCOMP)")
    return True
