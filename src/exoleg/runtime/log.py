"""Moved to :mod:`exoleg.session_log` (the session log's format is the ground floor's:
the controller's replay and the analyses read it as the runtime writes it). This path
re-exports it for one release."""

from exoleg.session_log import (  # noqa: F401
    MAGIC,
    MAX_LOSS_TICKS,
    SESSION_COLUMNS,
    SessionLog,
    check_session,
    header_problem,
    read_header,
    read_log,
)
