#!/usr/bin/env bash
# Install zenav and what it needs on this machine (Debian/Ubuntu, Python >= 3.11).
#   bash deploy/install.sh          # runtime: zenav + its Python dependencies
#   bash deploy/install.sh --test   # also the test tools and the system packages the tests use
set -euo pipefail
cd "$(dirname "$0")/.."
want_test=0
[[ "${1:-}" == "--test" ]] && want_test=1

apt_pkgs=()
command -v ip >/dev/null 2>&1 || apt_pkgs+=(iproute2)
if (( want_test )); then
  command -v socat >/dev/null 2>&1 || apt_pkgs+=(socat)
  command -v chromium >/dev/null 2>&1 || apt_pkgs+=(chromium)  # web viewer check (tests/monitor)
  [[ -x /usr/sbin/sshd ]] || apt_pkgs+=(openssh-server)  # zenav fleet's hosts (tests/fleet)
fi
if (( ${#apt_pkgs[@]} )); then
  if [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null 2>&1; then
    echo "zenav install: apt-get install ${apt_pkgs[*]}" >&2
    apt-get update -qq >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${apt_pkgs[@]}" >/dev/null
  else
    echo "zenav install: please install ${apt_pkgs[*]} (needs root); continuing" >&2
  fi
fi

extra="[physics]"   # MuJoCo for the simulator's `engine: mujoco`
(( want_test )) && extra="[physics,test]"
python3 -m pip install -q --disable-pip-version-check -e ".${extra}" 2>&1 | grep -v "Running pip as the 'root' user" || true
python3 -c "import zenoh, numpy, scipy, serial, msgpack, rerun, yaml, numba, mujoco" || { echo "zenav install: import check failed" >&2; exit 1; }
python3 -m deploy.warm_kernels || { echo "zenav install: compiling the numba kernels failed" >&2; exit 1; }
echo "zenav install: ok ($(command -v zenav || echo 'zenav not on PATH: use python3 -m deploy.cli'))" >&2
