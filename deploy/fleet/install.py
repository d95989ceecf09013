"""``zenav fleet install``: put this checkout on each host and make it a service (idempotent).

Per host, over ssh:
 1. check the host's Python (>= 3.11) and create install_dir/{etc,run,log}
 2. upload the checkout (``git ls-files``, tar over ssh) to install_dir/src (swapped in whole)
 3. a virtual environment install_dir/venv, made with ``--system-site-packages`` (so the Python packages
    already on the host — numpy, scipy, zenoh ... — are used instead of downloaded again; pip fetches
    only what is missing), and ``pip install -e src`` — re-run only when pyproject.toml changed.
    ``install_mode: link`` skips pip: a .pth file and a ``zenav`` script point the venv at src (for hosts
    that already have every dependency; no build, no index). Masters then compile the numba kernels once
    (``deploy.warm_kernels``) into install_dir/cache/numba (NUMBA_CACHE_DIR in zenav.env), which upgrades
    keep: only kernels whose source file changed are compiled again
 4. zenav.env, the Zenoh config (+ users file; + router.json5 for a secured robot / master) and
    service.json under install_dir/etc
 5. robots: the udev rule (/dev/pioneer) + udevadm reload when udevadm exists
 6. systemd hosts: the unit in /etc/systemd/system (+ daemon-reload, enable); a service user
Nothing is started (``zenav fleet up``). ``--dry-run`` prints every command and file instead.
"""

from __future__ import annotations

import shlex
import time

from deploy.fleet import render, secured, services
from deploy.fleet.inventory import Host, Inventory
from deploy.fleet.ssh import Remote

PY_CHECK = "import sys; assert sys.version_info >= (3, 11), sys.version; print(sys.version.split()[0])"


def install_host(inv: Inventory, r: Remote, echo=print, upload: bool = True) -> float:
    """Install (or update) one host; returns the seconds it took."""
    h, dry, t0 = r.host, r.dry_run, time.monotonic()
    p = render.paths(h)
    q = {k: shlex.quote(v) for k, v in p.items()}
    py = shlex.quote(h.python)
    ver = r.text(f"{py} -c {shlex.quote(PY_CHECK)} && mkdir -p {q['etc']} {q['run']} {q['log']}",
                 what=f"check {h.python} (Python >= 3.11 needed; set python: in the inventory)").strip()
    if not dry:
        echo(f"[{h.name}] Python {ver}; installing into {h.install_dir}")
    if upload:
        dt = r.put_checkout(p["src"], exclude=(inv.security.secrets_dir,))  # passwords stay here
        if not dry:
            echo(f"[{h.name}] checkout uploaded to {p['src']} ({dt:.1f} s)")
    no_pip = "--without-pip " if h.install_mode == "link" else ""  # ensurepip: the slow part, unused by link
    r.run(f"[ -x {q['python']} ] || {py} -m venv --system-site-packages {no_pip}{q['venv']}", what="create the venv",
          timeout=600)
    stamp = shlex.quote(f"{p['etc']}/pyproject.installed")
    if h.install_mode == "link":  # no pip: the venv points at src (dependencies must be there already)
        how = ("SP=$(" + q["python"] + " -c 'import sysconfig; print(sysconfig.get_paths()[\"purelib\"])') && "
               f"echo {q['src']} > \"$SP/zenav-src.pth\" && printf '%s\\n' '#!{p['python']}' 'import sys' "
               f"'from deploy.cli import main' 'sys.exit(main())' > {q['zenav']} && chmod 755 {q['zenav']}")
        what = "link the venv to src (install_mode: link)"
    else:
        pip_args = "".join(shlex.quote(a) + " " for a in h.pip_args)
        how = (f"{q['python']} -m pip install -q --disable-pip-version-check {pip_args}-e {q['src']} "
               f"> {q['log']}/pip.log 2>&1 || {{ tail -n 5 {q['log']}/pip.log; exit 1; }}")
        what = "pip install -e (zenav into the venv)"
    out = r.text(f"if cmp -s {q['src']}/pyproject.toml {stamp} && [ -x {q['zenav']} ]; then echo unchanged; else "
                 f"{how} && cp {q['src']}/pyproject.toml {stamp} && echo installed; fi", what=what, timeout=600)
    check = f"import zenoh, numpy, yaml, deploy.cli; assert deploy.cli.__file__.startswith({p['src']!r} + '/')"
    r.run(f"cd / && {q['python']} -c {shlex.quote(check)}",
          what="import check in the venv (zenoh, numpy, yaml, and zenav from src)", timeout=300)
    if h.role == "master":  # the planners' and SLAM's kernels, compiled once into a cache that upgrades keep
        r.run(f"mkdir -p {q['kernels']} && cd {q['src']} && NUMBA_CACHE_DIR={q['kernels']} {q['python']} -m "
              "deploy.warm_kernels", what="compile the numba kernels (once; unchanged files are kept)", timeout=600)
    if not dry:
        echo(f"[{h.name}] venv {p['venv']}: zenav {'already installed' if 'unchanged' in out else 'installed'}")
    _files(inv, r)
    if not dry:
        echo(f"[{h.name}] installed in {time.monotonic() - t0:.1f} s (service {h.service}, "
             f"{services.manager(r)})")
    return time.monotonic() - t0


def _files(inv: Inventory, r: Remote) -> None:
    h, dry = r.host, r.dry_run
    p = render.paths(h)
    r.put(p["env"], render.env_file(inv, h, dry))
    z = render.zenoh_json(inv, h, dry)
    if z is not None:
        r.put(p["router"] if h.role == "router" else p["zenoh"], z, mode="0600")
    if (router := render.router_json(inv, h, dry)) is not None:  # secured: the host's own router
        r.put(p["router"], router, mode="0600")
    if (users := render.users_txt(inv, h, dry)) is not None:
        r.put(p["users"], users, mode="0600")
    r.put(p["spec"], render.service_spec(h, secured.enabled(inv, h)))
    if h.role == "robot":
        r.put(p["udev"], render.udev_rules(h))
        r.run("if command -v udevadm >/dev/null && [ -d /run/udev ]; then udevadm control --reload-rules && "
              "udevadm trigger --subsystem-match=tty; else echo 'udevadm not running: rule applies at next boot'; fi",
              what="reload udev rules", check=False)
    if services.manager(r) == "systemd" or (dry and h.service_manager == "auto"):
        _systemd_unit(r, secured.enabled(inv, h))


def _systemd_unit(r: Remote, own_router: bool) -> None:
    h = r.host
    p = render.paths(h)
    user = shlex.quote(h.service_user)
    prefix = "# only with systemd: " if r.dry_run and h.service_manager == "auto" else ""
    if prefix:
        r._echo(f"+ [{h.name}] {prefix}the following unit and commands (supervisor otherwise)")
    r.run(f"id {user} >/dev/null 2>&1 || useradd --system --user-group --groups dialout --home-dir /var/lib/zenav "
          f"--create-home --shell /usr/sbin/nologin {user}; usermod -a -G dialout {user}; "
          f"chgrp -R {user} {shlex.quote(p['etc'])}; chmod -R g+rX {shlex.quote(h.install_dir)}; "
          f"if [ -d {shlex.quote(p['kernels'])} ]; then chgrp -R {user} {shlex.quote(p['kernels'])} && "
          f"chmod -R g+rwX {shlex.quote(p['kernels'])}; fi",
          what=f"service user {h.service_user}")
    r.put(p["unit"], render.unit(h, own_router))
    r.run(f"systemctl daemon-reload && systemctl enable {h.service}.service", what="systemctl enable")


def check_host(r: Remote) -> str:
    """One line: can we log in, and what runs there (used before install / by status)."""
    return r.text("uname -n; id -un", what="ssh login").replace("\n", " ").strip()


def install(inv: Inventory, hosts: list[Host], dry_run: bool = False, echo=print, parallel: bool = True) -> int:
    """Install on ``hosts``; returns the number of hosts that failed (each failure printed)."""
    from concurrent.futures import ThreadPoolExecutor

    from deploy.fleet import FleetError

    def one(h: Host) -> str:
        try:
            install_host(inv, Remote(h, dry_run), echo)
            return ""
        except FleetError as e:
            return str(e)

    if dry_run or not parallel:
        errors = [one(h) for h in hosts]
    else:
        with ThreadPoolExecutor(max_workers=min(4, len(hosts) or 1)) as ex:
            errors = list(ex.map(one, hosts))
    for h, e in zip(hosts, errors):
        if e:
            echo(f"[{h.name}] INSTALL FAILED: {e}")
    return sum(1 for e in errors if e)
