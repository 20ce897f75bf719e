"""The ``bw4t`` command from the Python package: the same command line as the Rust
executable (``bw4t --help``), run inside this process by the native module."""

from __future__ import annotations

import signal
import sys
from typing import List, Optional


def main(argv: Optional[List[str]] = None) -> int:
    """Runs ``bw4t`` with ``argv`` (default: this process's arguments); exits with its status."""
    from . import _native

    args = list(sys.argv if argv is None else ["bw4t", *argv])
    args[0] = "bw4t"
    # The command handles SIGINT and SIGTERM itself where it runs long; elsewhere they end
    # the process as they end the executable (Python's own handler would wait for Python).
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    sys.stdout.flush()
    sys.stderr.flush()
    # A child `bw4t serve` (some benchmarks start one) is this same command again.
    again = [sys.executable, "-m", "bw4t"]
    code = _native.cli_main(args, again)
    sys.exit(code)


if __name__ == "__main__":
    main()
