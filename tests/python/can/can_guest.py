#!/usr/bin/env python3
"""A throwaway Linux machine with a kernel CAN stack, for tests: a QEMU guest (TCG emulation).

This machine's kernel may have no AF_CAN; Debian's kernel package has it (modules can, can-raw,
can-dev, vcan). The guest boots that kernel with a busybox initramfs, makes ``vcan0``
(classical CAN) and ``vcan1`` (CAN FD, MTU 72), mounts the host's file tree read-only over
virtio-9p and runs each command in a chroot of it, so the host's own programs (the project's
nodes, its virtual environment, can-utils) run there unchanged, at the same paths. The guest has
its own tmpfs over /tmp, /run, /var/tmp and /dev/shm; the host folders the commands need
(``share``: by default this checkout, its virtual environment and the interpreter it links to)
are bound back over it, read-only. One folder of the host, the scratch folder, is mounted
writable at its own path: what a command writes there comes back to the host.

    with CanGuest(scratch) as guest:          # boots once (about 10 s)
        r = guest.run("candump -n 1 vcan0 & cansend vcan0 123#00; wait", timeout=30)
        r.rc, r.stdout, r.stderr, r.seconds

The host talks to a small command server (the guest's init, a busybox shell) over a second
serial port: the host writes a job's script into the scratch folder and names it on the serial
line; the guest runs it (in a chroot, cwd and environment as given, killed after its timeout),
keeps its stdout and stderr in its own memory and copies them to the scratch folder when the job
ends, syncs and answers with the exit status. Every process a job left running is killed when it
ends. Everything is bounded in time: the boot, each job, and the guest's whole life (it powers
itself off after ``max_seconds``; qemu dies with the Python process that started it).

Needs qemu-system-x86_64, a static busybox, cpio (Debian: qemu-system-x86, busybox-static,
cpio), and the kernel package that linux-image-amd64 depends on (downloaded with ``apt-get
download`` and unpacked into the cache folder, never installed). As root with apt-get the missing
packages are installed; otherwise :class:`GuestUnavailable` names them.

Command line: ``can_guest.py prepare`` (install, download, build the initramfs), ``can_guest.py
run [--timeout S] -- COMMAND`` (boot, run one shell command, print its output, exit with its
status).
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import hashlib
import lzma
import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType

#: Debian packages of the tools the guest needs, by the program each provides.
PACKAGES = {"qemu-system-x86_64": "qemu-system-x86", "busybox": "busybox-static",
            "cpio": "cpio", "candump": "can-utils"}
#: The meta package whose dependency names the versioned kernel image package.
KERNEL_META = "linux-image-amd64"
#: Kernel modules copied into the initramfs (loaded in the order of their dependencies).
MODULES = ("can", "can-raw", "can-dev", "vcan", "virtio", "virtio_ring",
           "virtio_pci_modern_dev", "virtio_pci_legacy_dev", "virtio_pci", "netfs", "fscache",
           "9pnet", "9pnet_virtio", "9p")
#: PATH of the jobs in the chroot (the host's programs).
GUEST_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"
#: The folders where the guest's programs write their own files: a tmpfs of the guest over each,
#: which hides the host's; the host folders the jobs need in them are bound back over it.
GUEST_TMPFS = ("/tmp", "/run", "/var/tmp", "/dev/shm")
#: The checkout this file belongs to.
CHECKOUT = Path(os.path.abspath(__file__)).parents[3]

INIT = r"""#!/bin/busybox sh
# /init of the CAN test guest (tests/python/can/can_guest.py): modules, vcan0/vcan1, the host tree
# read-only at /mnt with the guest's own tmpfs over its scratch folders (@TMPFS@), the host
# folders the jobs need bound back over those read-only, the scratch folder writable at its own
# path, then a command server on ttyS1. The scratch folder is also at /scratch (outside the
# chroot): its .guest/ names its own host path and the shared folders, one per line.
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc none /proc; mount -t sysfs none /sys; mount -t devtmpfs none /dev
arg() { tr ' ' '\n' < /proc/cmdline | sed -n "s/^rrr\.$1=//p"; }
MAXS=$(arg max); TTY=/dev/ttyS1
fail() { echo "RRR_GUEST_FAIL $*" > $TTY; echo "RRR_GUEST_FAIL $*"; sync; poweroff -f; }
MAXS=${MAXS:-900}
# the guest's whole life is bounded: restarted after each job (which kills every process but init)
watchdog() {
  left=$((MAXS - $(cut -d. -f1 /proc/uptime)))
  (sleep $left; echo "RRR_GUEST_FAIL lifetime of $MAXS s over" > $TTY; poweroff -f) &
}
watchdog
cd /lib/modules
for m in @MODULES@; do insmod $m.ko || fail "module $m did not load"; done
cd /
# vcan defaults to the CAN FD MTU (72): vcan0 is made classical (16)
ip link add dev vcan0 type vcan && ip link set vcan0 mtu 16 && ip link set up vcan0 ||
  fail "vcan0"
ip link add dev vcan1 type vcan && ip link set vcan1 mtu 72 && ip link set up vcan1 ||
  fail "vcan1"
mount -t 9p -o trans=virtio,version=9p2000.L,ro,msize=262144,cache=loose hostroot /mnt ||
  fail "9p mount of the host tree"
# /host: the host tree as it is, before the guest's own mounts cover parts of it in /mnt
mkdir -p /host /scratch /jobs; mount -o bind /mnt /host || fail "bind mount of the host tree"
mount -t proc none /mnt/proc; mount -t sysfs none /mnt/sys; mount -o bind /dev /mnt/dev
mkdir -p /dev/shm
for d in @TMPFS@; do mount -t tmpfs none "/mnt$d" || fail "tmpfs on $d"; done
mount -t 9p -o trans=virtio,version=9p2000.L,msize=262144 scratch /scratch ||
  fail "9p mount of the scratch folder"
# a shared folder: bound read-only at its own path; a symbolic link on the way to one: made again
while IFS= read -r p; do
  if [ -L "/host$p" ]; then
    [ -e "/mnt$p" ] || [ -L "/mnt$p" ] || { mkdir -p "$(dirname "/mnt$p")" &&
      ln -s "$(readlink "/host$p")" "/mnt$p"; } || fail "link $p"
  else
    mkdir -p "/mnt$p" && mount -o bind "/host$p" "/mnt$p" || fail "shared folder $p"
  fi
done < /scratch/.guest/shared
IFS= read -r SCRATCH < /scratch/.guest/scratch
mkdir -p "/mnt$SCRATCH" && mount -o bind /scratch "/mnt$SCRATCH" ||
  fail "the scratch folder at $SCRATCH"
stty -F $TTY raw -echo
exec 3<>$TTY
echo "RRR_GUEST_READY $(uname -r) $(cut -d' ' -f1 /proc/uptime)" >&3
while read -r op id secs <&3; do
  case "$op" in
  run)
    J=/scratch/.jobs/$id; T=/jobs/$id
    t0=$(cut -d' ' -f1 /proc/uptime)
    timeout -s KILL "$secs" chroot /mnt /bin/sh "$SCRATCH/.jobs/$id/job.sh" > $T.out 2> $T.err \
      < /dev/null
    rc=$?
    t1=$(cut -d' ' -f1 /proc/uptime)
    kill -KILL -1 2>/dev/null; watchdog
    cp $T.out $J/stdout; cp $T.err $J/stderr; rm -f $T.out $T.err
    echo "$rc $t0 $t1" > $J/status
    sync
    echo "RRR_GUEST_DONE $id $rc" >&3 ;;
  poweroff)
    sync; echo "RRR_GUEST_BYE" >&3; poweroff -f ;;
  esac
done
fail "command channel closed"
"""


class GuestUnavailable(RuntimeError):
    """The guest cannot be booted here: says what to install or what went wrong."""


class GuestError(RuntimeError):
    """The guest failed while running (boot, a lost command channel, a job past its bound)."""


@dataclass(frozen=True)
class Result:
    """One command in the guest: exit status (137 when killed at its timeout), its output, the
    wall time on the host and the time inside the guest (its uptime clock), in seconds."""

    rc: int
    stdout: str
    stderr: str
    seconds: float
    guest_seconds: float


def _missing_tools() -> list[str]:
    return [pkg for prog, pkg in PACKAGES.items() if shutil.which(prog) is None]


def _apt_install(packages: list[str]) -> None:
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    subprocess.run(["apt-get", "update", "-qq"], check=True, env=env,
                   stdout=subprocess.DEVNULL)
    subprocess.run(["apt-get", "install", "-y", "-qq", "--no-install-recommends", *packages],
                   check=True, env=env, stdout=subprocess.DEVNULL)


def _can_apt() -> bool:
    return os.geteuid() == 0 and shutil.which("apt-get") is not None


def ensure_tools() -> None:
    """qemu-system-x86_64, busybox (static), cpio and can-utils; installed with apt-get when
    missing and root, else GuestUnavailable naming the packages."""
    missing = _missing_tools()
    if missing and _can_apt():
        _apt_install(missing)
        missing = _missing_tools()
    if missing:
        raise GuestUnavailable("the CAN test guest needs " + ", ".join(missing) +
                               " (Debian: apt-get install " + " ".join(missing) + ")")
    busybox = shutil.which("busybox") or ""
    out = subprocess.run(["file", "-L", busybox], capture_output=True, text=True).stdout \
        if shutil.which("file") else ""
    if out and "statically linked" not in out:
        raise GuestUnavailable(f"{busybox} is not statically linked (Debian: apt-get install "
                               "busybox-static)")


def cache_dir() -> Path:
    """$RRR_CAN_GUEST_CACHE, else ~/.cache/rrr-can-guest."""
    env = os.environ.get("RRR_CAN_GUEST_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "rrr-can-guest"


def kernel_package() -> str:
    """$RRR_CAN_GUEST_KERNEL_PACKAGE, else the versioned image package linux-image-amd64
    depends on (apt-cache; after apt-get update when apt knows none)."""
    env = os.environ.get("RRR_CAN_GUEST_KERNEL_PACKAGE")
    if env:
        return env
    for attempt in range(2):
        out = subprocess.run(["apt-cache", "depends", KERNEL_META], capture_output=True,
                             text=True).stdout
        m = re.search(r"Depends:\s*(linux-image-\S+)", out)
        if m:
            return m.group(1)
        if attempt == 0 and _can_apt():
            subprocess.run(["apt-get", "update", "-qq"], check=True, stdout=subprocess.DEVNULL)
    raise GuestUnavailable(f"apt-cache names no kernel image package for {KERNEL_META} (run "
                           "apt-get update, or set RRR_CAN_GUEST_KERNEL_PACKAGE to a Debian "
                           "linux-image package)")


def ensure_kernel() -> Path:
    """A folder with ``vmlinuz`` and ``modules/*.ko`` of the kernel package (downloaded and
    unpacked once into the cache; the package is never installed)."""
    if shutil.which("apt-get") is None or shutil.which("dpkg") is None:
        raise GuestUnavailable("the CAN test guest takes its kernel from a Debian package "
                               f"({KERNEL_META}): apt-get and dpkg are needed")
    pkg = kernel_package()
    folder = cache_dir() / pkg
    if (folder / "vmlinuz").is_file() and all((folder / "modules" / f"{m}.ko").is_file()
                                              for m in MODULES):
        return folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=folder.parent, prefix=".download-") as tmp:
        os.chmod(tmp, 0o755)  # apt-get download as root drops to _apt where it can
        r = subprocess.run(["apt-get", "download", pkg], cwd=tmp, capture_output=True,
                           text=True)
        debs = list(Path(tmp).glob("*.deb"))
        if r.returncode != 0 or len(debs) != 1:
            raise GuestUnavailable(f"apt-get download {pkg} failed: {r.stderr.strip()}")
        unpacked = Path(tmp) / "x"
        subprocess.run(["dpkg", "-x", str(debs[0]), str(unpacked)], check=True)
        stage = Path(tmp) / "stage"
        (stage / "modules").mkdir(parents=True)
        vmlinuz = sorted((unpacked / "boot").glob("vmlinuz-*"))
        if len(vmlinuz) != 1:
            raise GuestUnavailable(f"{pkg}: no single boot/vmlinuz-* in the package")
        shutil.copy2(vmlinuz[0], stage / "vmlinuz")
        elf = _uncompressed_kernel(vmlinuz[0].read_bytes())
        if elf is not None:
            (stage / "vmlinux").write_bytes(elf)
        (stage / "release").write_text(vmlinuz[0].name[len("vmlinuz-"):] + "\n")
        kos = {p.name: p for p in unpacked.glob("lib/modules/*/kernel/**/*.ko")}
        for m in MODULES:
            if f"{m}.ko" not in kos:
                raise GuestUnavailable(f"{pkg}: has no module {m}.ko")
            shutil.copy2(kos[f"{m}.ko"], stage / "modules" / f"{m}.ko")
        if folder.exists():
            shutil.rmtree(folder)
        stage.rename(folder)
    return folder


def _uncompressed_kernel(bzimage: bytes) -> bytes | None:
    """The ELF kernel inside a bzImage compressed with xz or gzip (None for another format).
    QEMU boots it directly through its PVH entry point, without the real-mode setup and the
    decompression, which take about 25 s under emulation."""
    for magic, fmt in ((b"\xfd7zXZ\x00", "xz"), (b"\x1f\x8b\x08\x00", "gzip")):
        at = bzimage.find(magic)
        while at >= 0:
            try:
                if fmt == "xz":
                    out = lzma.LZMADecompressor(format=lzma.FORMAT_XZ).decompress(bzimage[at:])
                else:
                    out = zlib.decompressobj(16 + zlib.MAX_WBITS).decompress(bzimage[at:])
            except (lzma.LZMAError, zlib.error):
                out = b""
            if out[:4] == b"\x7fELF":
                return out
            at = bzimage.find(magic, at + 1)
    return None


def module_order(folder: Path) -> list[str]:
    """MODULES ordered so that each comes after the modules it depends on (their .modinfo)."""
    deps: dict[str, list[str]] = {}
    for m in MODULES:
        info = re.search(rb"(?:^|\x00)depends=([^\x00]*)\x00", (folder / f"{m}.ko").read_bytes())
        names = info.group(1).decode().split(",") if info and info.group(1) else []
        deps[m] = [n.replace("_", "-") if n.replace("_", "-") in MODULES else n for n in names]
    order: list[str] = []

    def visit(m: str, path: tuple[str, ...]) -> None:
        if m in order:
            return
        if m not in deps or m in path:
            raise GuestUnavailable(f"kernel module {path[-1]} needs {m}, which the guest "
                                   "does not load (or a dependency cycle)")
        for d in deps[m]:
            visit(d, (*path, m))
        order.append(m)

    for m in MODULES:
        visit(m, ())
    return order


def ensure_initramfs(kernel: Path) -> Path:
    """The initramfs (busybox, the modules, /init) for ``kernel``, built once per content."""
    busybox = Path(shutil.which("busybox") or "/bin/busybox")
    init = INIT.replace("@MODULES@", " ".join(module_order(kernel / "modules"))).replace(
        "@TMPFS@", " ".join(GUEST_TMPFS))
    digest = hashlib.sha256(init.encode() + busybox.read_bytes()
                            + (kernel / "release").read_bytes()).hexdigest()[:16]
    target = kernel / f"initramfs-{digest}.cpio"
    if target.is_file():
        return target
    with tempfile.TemporaryDirectory(dir=kernel, prefix=".initramfs-") as tmp:
        root = Path(tmp) / "root"
        for d in ("bin", "dev", "proc", "sys", "mnt", "tmp", "lib/modules"):
            (root / d).mkdir(parents=True)
        shutil.copy2(busybox, root / "bin" / "busybox")
        for ko in (kernel / "modules").glob("*.ko"):
            shutil.copy2(ko, root / "lib" / "modules" / ko.name)
        (root / "init").write_text(init)
        os.chmod(root / "init", 0o755)
        names = sorted(str(p.relative_to(root)) for p in root.rglob("*"))
        part = Path(tmp) / "initramfs.cpio"
        with open(part, "wb") as out:
            subprocess.run(["cpio", "--quiet", "-o", "-H", "newc"], cwd=root, check=True,
                           input="\n".join(names).encode() + b"\n", stdout=out)
        part.rename(target)
    return target


def prepare() -> tuple[Path, Path]:
    """Tools, kernel and initramfs: (kernel image, initramfs); the image is the uncompressed
    ELF kernel where it could be unpacked, else the bzImage."""
    ensure_tools()
    kernel = ensure_kernel()
    image = kernel / "vmlinux"
    return image if image.is_file() else kernel / "vmlinuz", ensure_initramfs(kernel)


def _under_guest_tmpfs(path: Path) -> bool:
    return any(path.is_relative_to(d) for d in GUEST_TMPFS)


def _entries(path: Path) -> list[Path]:
    """What the guest must recreate for ``path`` to resolve there as here: each symbolic link on
    the way that lies under a folder of GUEST_TMPFS, then the folder it ends in if it lies under
    one (symbolic links are followed; nothing is needed outside GUEST_TMPFS)."""
    out: list[Path] = []
    path = Path(os.path.abspath(path))
    for _ in range(40):  # a bound on the links followed (a loop of links)
        prefix = Path(path.anchor)
        for k, part in enumerate(path.parts[1:], start=1):
            prefix = prefix / part
            if prefix.is_symlink():
                if _under_guest_tmpfs(prefix):
                    out.append(prefix)
                target = Path(os.path.normpath(prefix.parent / os.readlink(prefix)))
                path = target.joinpath(*path.parts[k + 1:])
                break
        else:
            if path.is_dir() and _under_guest_tmpfs(path) and str(path) not in GUEST_TMPFS:
                out.append(path)
            return out
    raise ValueError(f"{path}: too many levels of symbolic links")


def default_shares(checkout: Path = CHECKOUT, python: Path = Path(sys.executable)) -> list[Path]:
    """The host folders a job needs at their own paths: the checkout, the virtual environment
    of ``python``, the interpreter that it links to (its prefix, wherever pyenv or the system
    keeps it) and the folders of this interpreter's ``sys.path`` (site-packages, and folders
    named by .pth files)."""
    python = Path(os.path.abspath(python))
    real = Path(os.path.realpath(python))
    return [checkout, python.parent.parent, real.parent.parent, Path(sys.prefix),
            Path(sys.base_prefix), *(Path(p) for p in sys.path if p and os.path.isdir(p))]


def guest_mounts(folders: list[Path]) -> list[Path]:
    """The paths the guest binds (folders) or links (symbolic links) for ``folders``, in the
    order it makes them: no folder inside another one, links after the folders."""
    entries = list(dict.fromkeys(e for f in folders for e in _entries(f)))
    for e in entries:
        if "\n" in str(e):
            raise ValueError(f"{e!r}: a shared folder with a newline in its path")
    dirs = sorted(e for e in entries if not e.is_symlink())
    kept = [d for d in dirs if not any(d != o and d.is_relative_to(o) for o in dirs)]
    links = [e for e in entries if e.is_symlink()
             and not any(e.is_relative_to(d) for d in kept)]
    return kept + links


def _opt(path: Path) -> str:
    """A path as the value of a QEMU option (a comma is written twice)."""
    return str(path).replace(",", ",,")


def _die_with_parent() -> None:  # runs in the child before exec
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


class CanGuest:
    """The guest: ``start()`` (or ``with``), :meth:`run` any number of commands, ``close()``.

    ``scratch``: the writable host folder (created). ``share``: the host folders that jobs see
    at their own paths even where the guest has its own tmpfs (GUEST_TMPFS: ``/tmp``, ...), read
    only; by default :func:`default_shares` (this checkout, its virtual environment and its
    interpreter). ``memory`` MiB, ``cpus`` emulated CPUs, ``boot_timeout`` and ``max_seconds``
    (the guest's whole life) in seconds.
    """

    def __init__(self, scratch: Path, *, share: list[Path] | None = None, memory: int = 1024,
                 cpus: int = 1, boot_timeout: float = 180.0, max_seconds: float = 1200.0) -> None:
        self.scratch = Path(scratch).resolve()
        if "\n" in str(self.scratch):
            raise ValueError(f"scratch folder {self.scratch!r}: a newline in its path")
        self.shared = guest_mounts(default_shares() if share is None else share)
        self.memory, self.cpus = memory, cpus
        self.boot_timeout, self.max_seconds = boot_timeout, max_seconds
        self.kernel_release = ""
        self.boot_seconds = 0.0
        self._proc: subprocess.Popen[bytes] | None = None
        self._sock: socket.socket | None = None
        self._buf = b""
        self._jobs = 0
        self._tmp: tempfile.TemporaryDirectory[str] | None = None
        self.console_log: Path | None = None

    # -- life cycle ---------------------------------------------------------------------------
    def start(self) -> CanGuest:
        vmlinuz, initrd = prepare()
        self.scratch.mkdir(parents=True, exist_ok=True)
        for old in (".jobs", ".guest"):  # a previous guest's
            shutil.rmtree(self.scratch / old, ignore_errors=True)
        (self.scratch / ".jobs").mkdir()
        (self.scratch / ".guest").mkdir()
        (self.scratch / ".guest" / "scratch").write_text(f"{self.scratch}\n")
        (self.scratch / ".guest" / "shared").write_text("".join(f"{p}\n" for p in self.shared))
        self._tmp = tempfile.TemporaryDirectory(prefix="rrr-can-guest-")
        sock_path = Path(self._tmp.name) / "ctl.sock"
        self.console_log = self.scratch / "console.log"
        # mitigations=off: a throwaway test machine; the emulated CPU spends less time on them
        append = (f"console=ttyS0 panic=-1 quiet loglevel=3 mitigations=off "
                  f"rrr.max={int(self.max_seconds)}")
        cmd = ["qemu-system-x86_64", "-accel", "tcg", "-cpu", "max", "-m", str(self.memory),
               "-smp", str(self.cpus), "-display", "none", "-monitor", "none", "-no-reboot",
               "-nodefaults",
               "-kernel", str(vmlinuz), "-initrd", str(initrd), "-append", append,
               "-chardev", f"file,id=console,path={_opt(self.console_log)}",
               "-serial", "chardev:console",
               "-chardev", f"socket,id=ctl,path={_opt(sock_path)},server=on,wait=off",
               "-serial", "chardev:ctl",
               "-fsdev", "local,id=r,path=/,security_model=none,readonly=on,multidevs=remap",
               "-device", "virtio-9p-pci,fsdev=r,mount_tag=hostroot",
               "-fsdev", f"local,id=s,path={_opt(self.scratch)},security_model=none",
               "-device", "virtio-9p-pci,fsdev=s,mount_tag=scratch"]
        t0 = time.monotonic()
        self._proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, preexec_fn=_die_with_parent)
        try:
            self._connect(sock_path, t0 + 30.0)
            line = self._read_line(t0 + self.boot_timeout, "the boot")
            if not line.startswith("RRR_GUEST_READY "):
                raise GuestError(f"the guest did not boot: {line}{self._console_tail()}")
            self.kernel_release = line.split()[1]
        except BaseException:
            self.close()
            raise
        self.boot_seconds = time.monotonic() - t0
        return self

    def _connect(self, path: Path, deadline: float) -> None:
        while True:
            if self._proc is not None and self._proc.poll() is not None:
                out = self._proc.stdout.read().decode(errors="replace") \
                    if self._proc.stdout else ""
                raise GuestUnavailable(f"qemu-system-x86_64 exited with {self._proc.returncode}"
                                       f": {out.strip()}")
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                s.connect(str(path))
                self._sock = s
                return
            except OSError:
                s.close()
                if time.monotonic() > deadline:
                    raise GuestError("qemu's command channel did not appear") from None
                time.sleep(0.05)

    def _read_line(self, deadline: float, what: str) -> str:
        assert self._sock is not None
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise GuestError(f"the guest gave no answer in time ({what})"
                                 + self._console_tail())
            self._sock.settimeout(min(left, 1.0))
            try:
                chunk = self._sock.recv(4096)
            except TimeoutError:
                if self._proc is not None and self._proc.poll() is not None:
                    raise GuestError(f"qemu exited with {self._proc.returncode} during {what}"
                                     + self._console_tail()) from None
                continue
            if not chunk:
                raise GuestError(f"the guest closed its command channel during {what}"
                                 + self._console_tail())
            self._buf += chunk
        line, _, self._buf = self._buf.partition(b"\n")
        text = line.decode(errors="replace").strip("\r\x00 ")
        if text.startswith("RRR_GUEST_FAIL"):
            raise GuestError(f"the guest failed: {text}" + self._console_tail())
        return text

    def _console_tail(self, n: int = 30) -> str:
        if self.console_log is None or not self.console_log.is_file():
            return ""
        lines = self.console_log.read_text(errors="replace").splitlines()[-n:]
        return "\nlast lines of the guest console:\n" + "\n".join(lines) if lines else ""

    def close(self) -> None:
        """Power the guest off (sync first) and wait for qemu; kill it if it hangs."""
        proc, self._proc = self._proc, None
        if proc is not None and proc.poll() is None and self._sock is not None:
            with contextlib.suppress(OSError, GuestError):
                self._sock.sendall(b"poweroff - 0\n")
                self._read_line(time.monotonic() + 20.0, "the power-off")
        if proc is not None:
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            if proc.stdout:
                proc.stdout.close()
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    def __enter__(self) -> CanGuest:
        return self.start() if self._proc is None else self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # -- commands -----------------------------------------------------------------------------
    def run(self, command: str | list[str], *, timeout: float = 120.0, cwd: Path | None = None,
            env: dict[str, str] | None = None) -> Result:
        """Run ``command`` (a shell command line, or an argv list) in the chroot of the host
        tree; ``cwd`` (default: the scratch folder) and ``env`` (added to a clean environment
        with PATH, HOME=/tmp and LANG=C.UTF-8). Killed after ``timeout`` s (status 137); a
        guest that does not answer within ``timeout`` + 30 s raises GuestError."""
        if self._proc is None or self._sock is None:
            raise GuestError("the guest is not running")
        self._jobs += 1
        job = self.scratch / ".jobs" / str(self._jobs)
        job.mkdir(parents=True)
        line = command if isinstance(command, str) else shlex.join(command)
        environ = {"PATH": GUEST_PATH, "HOME": "/tmp", "LANG": "C.UTF-8",
                   "MPLCONFIGDIR": "/tmp/.mpl", "PYTHONDONTWRITEBYTECODE": "1", **(env or {})}
        exports = "".join(f"export {k}={shlex.quote(v)}\n" for k, v in environ.items())
        (job / "job.sh").write_text(f"cd {shlex.quote(str(cwd or self.scratch))} || exit 126\n"
                                    f"{exports}{line}\n")
        secs = max(1, int(timeout + 0.999))
        t0 = time.monotonic()
        self._sock.sendall(f"run {self._jobs} {secs}\n".encode())
        answer = self._read_line(t0 + secs + 30.0, f"job {self._jobs}: {line[:80]}")
        seconds = time.monotonic() - t0
        m = re.fullmatch(rf"RRR_GUEST_DONE {self._jobs} (\d+)", answer)
        if m is None:
            raise GuestError(f"unexpected answer of the guest: {answer!r}")
        status = (job / "status").read_text().split()
        return Result(rc=int(m.group(1)), stdout=(job / "stdout").read_text(errors="replace"),
                      stderr=(job / "stderr").read_text(errors="replace"), seconds=seconds,
                      guest_seconds=float(status[2]) - float(status[1]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="action", required=True)
    sub.add_parser("prepare", help="install the tools, fetch the kernel, build the initramfs")
    r = sub.add_parser("run", help="boot the guest, run one shell command, print its output")
    r.add_argument("--timeout", type=float, default=120.0)
    r.add_argument("--scratch", type=Path, help="writable folder (default: a temporary one)")
    r.add_argument("--cpus", type=int, default=1)
    r.add_argument("--memory", type=int, default=1024)
    r.add_argument("command", nargs=argparse.REMAINDER)
    opt = ap.parse_args(argv)
    try:
        if opt.action == "prepare":
            vmlinuz, initrd = prepare()
            print(f"kernel {vmlinuz}, initramfs {initrd}")
            return 0
        words = opt.command[1:] if opt.command[:1] == ["--"] else opt.command
        if not words:
            ap.error("run: a command is needed")
        with contextlib.ExitStack() as stack:
            scratch = opt.scratch or Path(stack.enter_context(
                tempfile.TemporaryDirectory(prefix="rrr-can-scratch-")))
            guest = stack.enter_context(CanGuest(scratch, cpus=opt.cpus, memory=opt.memory))
            print(f"[guest: kernel {guest.kernel_release}, booted in {guest.boot_seconds:.1f} s]",
                  file=sys.stderr)
            res = guest.run(" ".join(words), timeout=opt.timeout)
        sys.stdout.write(res.stdout)
        sys.stderr.write(res.stderr)
        print(f"[guest: exit {res.rc} in {res.seconds:.1f} s]", file=sys.stderr)
        return res.rc
    except (GuestUnavailable, GuestError) as exc:
        print(f"can_guest: {exc}", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
