"""A network link between two namespaces with delay, loss and partitions, in user space.

This kernel has no ``sch_netem`` (``tc qdisc add ... netem`` fails: "Specified qdisc kind is unknown"),
so the test link is two TUN devices, one in each namespace, and this process forwards the IP packets
between them: each packet is delayed by ``delay`` seconds and dropped with probability ``loss``; while
partitioned every packet is dropped. Real packets, so TCP retransmits and Zenoh's leases expire as on
a bad Wi-Fi link.

    python linkem.py NS_A ADDR_A NS_B ADDR_B      (ADDR like 10.78.0.1/24; runs until stdin closes)

stdin commands, one per line: ``delay S``, ``loss P``, ``partition`` / ``heal``. Prints ``READY`` once
both ends are up, then ``OK <command>`` after each command, and ``STATS fwd=N drop=M`` on ``stats``.
"""

from __future__ import annotations

import fcntl
import heapq
import os
import random
import select
import struct
import subprocess
import sys
import threading
import time

TUNSETIFF = 0x400454CA
IFF_TUN, IFF_NO_PI = 0x0001, 0x1000


def open_tun(name: str) -> int:
    fd = os.open("/dev/net/tun", os.O_RDWR)
    fcntl.ioctl(fd, TUNSETIFF, struct.pack("16sH", name.encode(), IFF_TUN | IFF_NO_PI))
    return fd


def ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True, timeout=30)


class Link:
    def __init__(self, ends: list[tuple[str, str]], seed: int = 7) -> None:
        self.delay, self.loss, self.cut = 0.0, 0.0, False
        self.fwd = self.drop = 0
        self.rng = random.Random(seed)
        self.lock = threading.Lock()
        self.fds = []
        for i, (ns, addr) in enumerate(ends):
            dev = f"zlk{os.getpid() % 100000}{i}"
            self.fds.append(open_tun(dev))
            ip("link", "set", dev, "netns", ns)  # the open fd keeps working in the other namespace
            ip("-n", ns, "addr", "add", addr, "dev", dev)
            ip("-n", ns, "link", "set", dev, "multicast", "on")
            ip("-n", ns, "link", "set", dev, "up")
            ip("-n", ns, "link", "set", "lo", "up")
            ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", dev)
        self.queue: list[tuple[float, int, int, bytes]] = []  # (due, seq, out fd, packet)
        self.seq = 0

    def run(self) -> None:
        a, b = self.fds
        peer = {a: b, b: a}
        while True:
            timeout = 0.05
            if self.queue:
                timeout = max(0.0, min(timeout, self.queue[0][0] - time.monotonic()))
            ready, _, _ = select.select([a, b], [], [], timeout)
            now = time.monotonic()
            for fd in ready:
                pkt = os.read(fd, 65535)
                with self.lock:
                    if self.cut or self.rng.random() < self.loss:
                        self.drop += 1
                        continue
                    self.seq += 1
                    heapq.heappush(self.queue, (now + self.delay, self.seq, peer[fd], pkt))
            while self.queue and self.queue[0][0] <= time.monotonic():
                _, _, out, pkt = heapq.heappop(self.queue)
                try:
                    os.write(out, pkt)
                    self.fwd += 1
                except OSError:
                    self.drop += 1

    def command(self, line: str) -> str:
        words = line.split()
        with self.lock:
            if words[:1] == ["delay"]:
                self.delay = float(words[1])
            elif words[:1] == ["loss"]:
                self.loss = float(words[1])
            elif words == ["partition"]:
                self.cut = True
            elif words == ["heal"]:
                self.cut = False
            elif words == ["stats"]:
                return f"STATS fwd={self.fwd} drop={self.drop}"
            else:
                return f"ERR {line}"
        return f"OK {line}"


def main() -> None:
    ns_a, addr_a, ns_b, addr_b = sys.argv[1:5]
    link = Link([(ns_a, addr_a), (ns_b, addr_b)])
    threading.Thread(target=link.run, daemon=True).start()
    print("READY", flush=True)
    for line in sys.stdin:
        if line.strip():
            print(link.command(line.strip()), flush=True)


if __name__ == "__main__":
    main()
