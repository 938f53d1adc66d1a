"""Where a measurement was made: the machine and the git commit, for benchmark rows and reports
(bench/RESULTS.md rows carry machine, commit, command, figure)."""
import os
import platform
import subprocess


def machine() -> str:
    """CPU model (from /proc/cpuinfo where there is one) and core count."""
    model = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores"


def commit(cwd: str = None) -> str:
    """Short hash of HEAD in the repository holding `cwd` (default: this package's), with
    "-dirty" when tracked files differ from it; "unknown" outside a git checkout."""
    cwd = cwd or os.path.dirname(os.path.abspath(__file__))
    try:
        h = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=cwd, capture_output=True, text=True,
                           check=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=cwd,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return h + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def cpu_busy_seconds() -> float:
    """CPU seconds the whole machine has spent busy so far (user, nice, system, irq, softirq, steal; from
    /proc/stat); NaN where there is no /proc/stat. With own_cpu_seconds() it gives the CPU other work took
    during a measurement."""
    try:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:9]]
        return (v[0] + v[1] + v[2] + v[5] + v[6] + v[7]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError):
        return float("nan")


def own_cpu_seconds() -> float:
    """CPU seconds of this process and its finished children (worker processes, peer renderers)."""
    import resource
    t = 0.0
    for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN):
        r = resource.getrusage(who)
        t += r.ru_utime + r.ru_stime
    return t
