"""Starting a command in a test as a shell starts it."""

import signal


def as_from_a_shell() -> None:
    """``preexec_fn`` of a command a test will interrupt: SIGINT at its default action and not blocked, as a shell
    starts a command, whatever the test worker's own SIGINT is (a library run earlier in the same pytest-xdist
    worker may have left it ignored or blocked, and a child inherits both: the command would then run on past
    the interrupt to exit 0, as two full runs of the suite saw)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
