"""The guard of the benches that start Ray: only inside a loopback-only network namespace."""
import sys


def refuse_unless_loopback_only() -> bool:
    """True (after saying why on stderr) when this network namespace has a device besides `lo`:
    Ray binds every interface, so a bench starts it only under `unshare -n` (see each --help)."""
    with open("/proc/net/dev") as f:  # this namespace's devices (not /sys/class/net's)
        devices = sorted(line.split(":")[0].strip() for line in f.readlines()[2:])
    if devices == ["lo"]:
        return False
    print("refusing to start Ray: run in a loopback-only network namespace (unshare -n, see --help)", file=sys.stderr)
    return True
