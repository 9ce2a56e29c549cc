"""The error and the warning a record raises: one that cannot be read or used, and one written
by other versions or whose map has changed."""

from __future__ import annotations

from ..errors import JacoError


class RecordError(JacoError):
    """A record file that cannot be read or used (missing, not a jaco record, inconsistent)."""


class RecordWarning(UserWarning):
    """A record written by other versions, or whose map no longer matches its hash."""
