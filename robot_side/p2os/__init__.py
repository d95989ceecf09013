"""Pioneer base over the P2OS / ARCOS serial protocol: pure packets (protocol, sip), the serial driver,
the bus node and a simulated device (fake_robot) for tests and for trying the driver without a robot."""
