"""Remote commands through the system ``ssh`` client (subprocess; no Python SSH library).

``Remote(host, dry_run)`` runs shell commands on one host, uploads files (content on stdin) and this
checkout (``git ls-files`` as a tar stream). With ``dry_run`` every command is printed (``+ ssh ...``)
and nothing runs; the echo goes to ``out``. BatchMode: a host that asks for a password fails at once.
"""

from __future__ import annotations

import io
import os
import shlex
import subprocess
import sys
import tarfile
import time
from pathlib import Path

from deploy.fleet import FleetError
from deploy.fleet.inventory import Host

CHECKOUT = Path(__file__).resolve().parents[2]


def ssh_argv(host: Host, *extra: str) -> list[str]:
    """ssh with the host's user, port, key and options; connections are shared (ControlMaster: one
    login per host for the many short commands of an install, kept 15 s after the last one)."""
    s = host.ssh
    argv = ["ssh", "-p", str(s.port), "-o", "BatchMode=yes", "-o", "ConnectTimeout=10",
            "-o", "ServerAliveInterval=5", "-o", "LogLevel=ERROR", "-o", "ControlMaster=auto",
            "-o", f"ControlPath=/tmp/zenav-fleet-{os.getuid()}-%C", "-o", "ControlPersist=15"]
    if s.key:
        argv += ["-i", s.key, "-o", "IdentitiesOnly=yes"]
    for o in s.options:
        argv += ["-o", o]
    return [*argv, *extra, f"{s.user}@{host.address}"]


def checkout_files(root: Path = CHECKOUT) -> list[str]:
    """The checkout's files as on disk now: tracked, plus new ones git does not ignore (``git ls-files
    --cached --others --exclude-standard``); every file when it is not a git tree."""
    r = subprocess.run(["git", "-C", str(root), "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                       capture_output=True, timeout=60)
    if r.returncode == 0:
        return [f for f in r.stdout.decode().split("\0") if f and (root / f).is_file()]
    return [str(p.relative_to(root)) for p in root.rglob("*") if p.is_file() and ".git" not in p.parts]


def checkout_tar(root: Path = CHECKOUT, exclude: tuple[str, ...] = ()) -> bytes:
    """The checkout as a tar.gz, without files under ``exclude`` (e.g. the fleet's secrets_dir)."""
    skip = [Path(e).resolve() for e in exclude if e]
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz", compresslevel=3) as tar:
        for f in checkout_files(root):
            if any((root / f).resolve().is_relative_to(d) for d in skip):
                continue
            tar.add(str(root / f), arcname=f, recursive=False)
    return buf.getvalue()


class Remote:
    def __init__(self, host: Host, dry_run: bool = False, out=None, verbose: bool = False):
        self.host, self.dry_run, self.verbose = host, dry_run, verbose
        self.out = out or sys.stdout

    def _echo(self, text: str) -> None:
        print(text, file=self.out, flush=True)

    def run(self, command: str, *, stdin: bytes | None = None, check: bool = True, timeout: float = 120,
            what: str = "", quiet_dry: bool = False) -> subprocess.CompletedProcess:
        """Run ``command`` (a shell line) on the host; FleetError with its stderr when it fails."""
        argv = [*ssh_argv(self.host), command]
        if self.dry_run or self.verbose:
            if not quiet_dry:
                self._echo(f"+ [{self.host.name}] " + " ".join(shlex.quote(a) for a in argv)
                           + (f"  < ({len(stdin)} bytes)" if stdin is not None else ""))
            if self.dry_run:
                return subprocess.CompletedProcess(argv, 0, b"", b"")
        try:
            r = subprocess.run(argv, input=stdin if stdin is not None else b"", capture_output=True,
                               timeout=timeout)
        except subprocess.TimeoutExpired:
            raise FleetError(f"{self.host.name}: {what or command!r} did not finish in {timeout:.0f} s") from None
        if check and r.returncode != 0:
            err = (r.stderr or r.stdout).decode(errors="replace").strip().splitlines()
            hint = ""
            if r.returncode == 255:
                hint = (f" (ssh could not log in to {self.host.ssh.user}@{self.host.address}:{self.host.ssh.port}:"
                        " check the address, that sshd runs, and the key in the inventory's ssh.key)")
            raise FleetError(f"{self.host.name}: {what or command!r} failed (exit {r.returncode}){hint}: "
                             + " | ".join(err[-4:]))
        return r

    def text(self, command: str, **kw) -> str:
        return self.run(command, **kw).stdout.decode(errors="replace")

    def put(self, path: str, content: str | bytes, mode: str = "0644", show: bool = True) -> None:
        """Write ``content`` to ``path`` on the host (parent directories created)."""
        data = content.encode() if isinstance(content, str) else content
        q = shlex.quote(path)
        if self.dry_run:
            self._echo(f"+ [{self.host.name}] write {path} (mode {mode}):")
            if show:
                secret = "password" in path or path.endswith((".key", "users.txt"))
                for line in ("(secret, not shown)",) if secret else data.decode(errors="replace").splitlines():
                    self._echo(f"|   {line}")
            return
        tmp = f"{q}.tmp.$$"
        self.run(f"mkdir -p \"$(dirname {q})\" && cat > {tmp} && chmod {mode} {tmp} && mv -f {tmp} {q}",
                 stdin=data, what=f"write {path}")

    def put_checkout(self, dest: str, exclude: tuple[str, ...] = ()) -> float:
        """Replace ``dest`` by this checkout's tracked files (unpacked aside, then swapped in; the previous
        tree stays as ``dest.old`` until the next upload, so a running service keeps its working
        directory until it is restarted). Returns the seconds it took."""
        t0 = time.monotonic()
        data = b"" if self.dry_run else checkout_tar(CHECKOUT, exclude)
        d = shlex.quote(dest)
        if self.dry_run:
            self._echo(f"+ git ls-files | tar cz | ssh {self.host.ssh.user}@{self.host.address} "
                       f"'unpack into {dest}.new, then swap it with {dest}'  ({len(checkout_files())} files)")
            return 0.0
        self.run(f"rm -rf {d}.new && mkdir -p {d}.new && tar xzf - -C {d}.new && "
                 f"rm -rf {d}.old && {{ [ ! -e {d} ] || mv {d} {d}.old; }} && mv {d}.new {d}",
                 stdin=data, timeout=300, what=f"upload the checkout to {dest}")
        return time.monotonic() - t0

    def stream(self, command: str) -> int:
        """Run with the output going straight to this terminal (logs -f); the exit status."""
        argv = [*ssh_argv(self.host), command]
        if self.dry_run:
            self._echo("+ " + " ".join(shlex.quote(a) for a in argv))
            return 0
        return subprocess.call(argv, stdin=subprocess.DEVNULL)
