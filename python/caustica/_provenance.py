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
