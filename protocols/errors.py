"""The single exception type for every wire problem.

Anything that goes wrong between a Python message object and the bytes on the wire
(an invalid key expression, an unknown encoding string, malformed JSON, a value out of
range, a cross-field rule broken, a non-finite float on encode) raises
:class:`ProtocolError`. Adapters catch exactly this type, log it and count the
rejection by :attr:`ProtocolError.reason`; nothing else escapes the codec.
"""

from __future__ import annotations

__all__ = ["ProtocolError", "REJECT_REASONS"]

#: Values of :attr:`ProtocolError.reason`, suitable as counter names.
REJECT_REASONS: frozenset[str] = frozenset(
    {
        "invalid",  # a value breaks a type, range or cross-field rule
        "malformed",  # the payload is not parseable JSON
        "oversize",  # the payload exceeds the size limit
        "encoding",  # the encoding string is missing, malformed or unknown
        "unexpected_type",  # the encoding names another type than the caller expects
        "key",  # a key expression, prefix or id is invalid
    }
)


class ProtocolError(ValueError):
    """A message, payload, encoding string or key expression is not acceptable.

    Parameters
    ----------
    message : str
        Human-readable explanation. When a field is involved the message names it
        (by name, or by its msgspec-style path such as ``$.range_m``).
    field : str or None, optional
        msgspec-style path of the offending field (``$.vehicle_position_enu_m[1]``,
        ``$.prediction[0].position_cov_m2``), or None when no single field is to
        blame (oversized payload, unknown encoding, malformed JSON).
    reason : str, optional
        Short machine-readable category, one of :data:`REJECT_REASONS`; daemons
        count rejections under it. Default ``"invalid"``.

    Notes
    -----
    Subclassing :class:`ValueError` matters: msgspec converts a ``ValueError`` raised
    in a Struct's ``__post_init__`` during decoding into ``msgspec.ValidationError``,
    keeping the original exception as ``__context__`` so the codec can recover
    :attr:`field`.
    """

    def __init__(self, message: str, *, field: str | None = None, reason: str = "invalid") -> None:
        if reason not in REJECT_REASONS:
            raise ValueError(f"unknown ProtocolError reason {reason!r}")
        super().__init__(message)
        self.field: str | None = field
        self.reason: str = reason

    @property
    def message(self) -> str:
        """The human-readable message (same as ``str(error)``)."""
        return str(self.args[0])

    def __repr__(self) -> str:
        return f"ProtocolError({self.message!r}, field={self.field!r}, reason={self.reason!r})"
