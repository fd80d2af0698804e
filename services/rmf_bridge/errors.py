"""What the building bridge refuses, one type per reason, each a one-line message.

The node maps them to a counter and a log line (``KINDS``): a refused message is
dropped, the bridge goes on.
"""

from __future__ import annotations


class BridgeError(ValueError):
    """Base of everything the bridge refuses."""

    kind = "bad"


class MalformedCdr(BridgeError):
    """A payload that is not a CDR-encoded message of the expected Open-RMF type."""

    kind = "malformed"


class BadField(BridgeError):
    """A message that decodes but holds a value the other side cannot take (a door mode
    outside ``DoorMode``, a stamp beyond ``builtin_interfaces/Time``), naming the field."""

    kind = "bad_field"


class UnknownName(BridgeError):
    """A door or lift the site does not list as reported by the building (no such id, or
    ``controller: false``), or a building name no site door or lift maps to."""

    kind = "unknown"


KINDS = (MalformedCdr.kind, BadField.kind, UnknownName.kind)
