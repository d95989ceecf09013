#!/usr/bin/env bash
# Install zenav as a system service on the robot PC (or the master PC: --role master).
#   sudo bash deploy/hosts/install-robot.sh [--role robot|master] [--robot NAME] [--config YAML]
#        [--zenoh-config JSON5] [--adapter all|ftdi|prolific|cp210x|ch340] [--router] [--no-pip]
#        [--start] [--dry-run] [--render DIR]
# Does: deploy/install.sh (zenav + Python deps); system user `zenav` in group dialout; udev rule
# /dev/pioneer (robot); /etc/zenav/{zenav.env[,zenoh.json5]}; systemd unit zenav-<role>.service
# (ExecStart=zenav <role> --config <YAML, absolute, in this checkout>, Restart=on-failure); enables it.
# The checkout and the zenav executable must be readable by the `zenav` user (e.g. /opt/zenav, not /root).
# --dry-run prints every action and file without changing anything; --render DIR only writes the
# rendered files into DIR (review them, or `systemd-analyze verify DIR/*.service`).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
repo="$(cd "$here/../.." && pwd)"

role=robot robot="$(hostname -s 2>/dev/null || echo robot)" config="" zconf="" adapter=all
router=0 pip=1 start=0 dry=0 render=""
die() { echo "install-robot: $*" >&2; exit 2; }
while (( $# )); do
  case "$1" in
    --role) role="${2:?}"; shift ;;
    --robot) robot="${2:?}"; shift ;;
    --config) config="${2:?}"; shift ;;
    --zenoh-config) zconf="${2:?}"; shift ;;
    --adapter) adapter="${2:?}"; shift ;;
    --router) router=1 ;;
    --no-pip) pip=0 ;;
    --start) start=1 ;;
    --dry-run) dry=1 ;;
    --render) render="${2:?}"; shift ;;
    -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
    *) die "unknown option $1 (see --help)" ;;
  esac
  shift
done
[[ "$role" == robot || "$role" == master ]] || die "--role must be robot or master"
[[ "$robot" =~ ^[A-Za-z0-9_.-]+$ ]] || die "--robot must be letters, digits, _ . - (got '$robot')"
case "$adapter" in all|ftdi|prolific|cp210x|ch340) ;; *) die "--adapter: all|ftdi|prolific|cp210x|ch340" ;; esac
if [[ -z "$config" ]]; then
  if [[ "$role" == robot ]]; then config="$repo/robot_side/config/p3at_sim.yaml"
  else config="$repo/master_side/config/p3at_known_map.yaml"; fi
fi
[[ -f "$config" ]] || die "--config $config: no such file"
config="$(cd "$(dirname "$config")" && pwd)/$(basename "$config")"
[[ -z "$zconf" || -f "$zconf" ]] || die "--zenoh-config $zconf: no such file"
if (( ! dry )) && [[ -z "$render" ]] && [[ $(id -u) -ne 0 ]]; then
  die "run as root (sudo), or use --dry-run / --render DIR"
fi

zenav_bin="$(command -v zenav || echo /usr/local/bin/zenav)"
case "$repo:$zenav_bin" in
  /root/*|*:/root/*) echo "install-robot: WARNING the checkout ($repo) or zenav ($zenav_bin) is under /root:" \
                          "the zenav user cannot read it; clone to /opt/zenav and install from there" >&2 ;;
esac
etc=/etc/zenav
run() { if (( dry )); then echo "+ $*"; else "$@"; fi; }

# -- rendered files (text on stdout) ----------------------------------------------------------------
render_unit() {  # $1 = robot|master|router
  sed -e "s#@ZENAV_BIN@#${zenav_bin}#g" -e "s#@CONFIG@#${config}#g" -e "s#@REPO@#${repo}#g" \
    "$here/zenav-$1.service"
}
render_env() {
  sed -e "s#@ROBOT@#${robot}#g" "$here/zenav.env" |
    if [[ -n "$zconf" ]]; then sed -e "s|^#ZENAV_ZENOH_CONFIG=.*|ZENAV_ZENOH_CONFIG=${etc}/zenoh.json5|"; else cat; fi
}
render_rules() {
  if [[ "$adapter" == all ]]; then cat "$here/99-pioneer.rules"; return; fi
  awk -v a="$adapter" '/^# [a-z0-9]+ +/ {keep = ($2 == a)} /^SUBSYSTEM/ {if (keep) print; next} /^#/ {print}' \
    "$here/99-pioneer.rules"
}
put() {  # put DEST MODE < content
  local dest="$1" mode="$2" tmp
  if (( dry )); then
    echo "+ write $dest (mode $mode):"; sed 's/^/|   /'
  else
    tmp="$(mktemp)"; cat >"$tmp"; install -D -m "$mode" "$tmp" "$dest"; rm -f "$tmp"
  fi
}

if [[ -n "$render" ]]; then
  mkdir -p "$render"
  render_unit "$role" >"$render/zenav-$role.service"
  (( router )) && render_unit router >"$render/zenav-router.service"
  render_env >"$render/zenav.env"
  [[ "$role" == robot ]] && render_rules >"$render/99-pioneer.rules"
  echo "install-robot: rendered into $render" >&2
  exit 0
fi

# -- 1. zenav itself ------------------------------------------------------------------------------------
(( pip )) && run bash "$repo/deploy/install.sh"
# -- 2. service user --------------------------------------------------------------------------------
if id zenav >/dev/null 2>&1; then
  run usermod -a -G dialout zenav
else
  run useradd --system --user-group --groups dialout --home-dir /var/lib/zenav --create-home \
    --shell /usr/sbin/nologin zenav
fi
# -- 3. udev rule: /dev/pioneer (robot PC only) ------------------------------------------------------
if [[ "$role" == robot ]]; then
  render_rules | put /etc/udev/rules.d/99-pioneer.rules 0644
  if command -v udevadm >/dev/null 2>&1; then
    run udevadm control --reload-rules
    run udevadm trigger --subsystem-match=tty
  else
    echo "install-robot: udevadm not found: the rule applies at next boot / replug" >&2
  fi
fi
# -- 4. /etc/zenav: env file (kept if present), Zenoh config -----------------------------------
if [[ -f "$etc/zenav.env" && $dry -eq 0 ]]; then
  echo "install-robot: keeping existing $etc/zenav.env" >&2
else
  render_env | put "$etc/zenav.env" 0644
fi
[[ -n "$zconf" ]] && put "$etc/zenoh.json5" 0640 <"$zconf" && run chgrp zenav "$etc/zenoh.json5"  # may hold a password
# -- 5. systemd units -------------------------------------------------------------------------------
units=("zenav-$role.service")
(( router )) && units+=(zenav-router.service)
for u in "${units[@]}"; do
  name="${u#zenav-}"; render_unit "${name%.service}" | put "/etc/systemd/system/$u" 0644
done
if command -v systemctl >/dev/null 2>&1; then
  run systemctl daemon-reload
  if (( start )); then run systemctl enable --now "${units[@]}"; else run systemctl enable "${units[@]}"; fi
else
  echo "install-robot: systemctl not found: start with  $zenav_bin $role --config $config" >&2
fi
echo "install-robot: done (${units[*]}; $( ((start)) && echo started || echo "start: systemctl start ${units[0]}"));" \
     "check with: zenav doctor --robot $robot$([[ $role == robot ]] && echo ' --serial /dev/pioneer')" >&2
