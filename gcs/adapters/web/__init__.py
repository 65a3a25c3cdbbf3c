"""The live map: a page served over HTTP with Server-Sent Events (:mod:`gcs.adapters.web.server`).

The page itself (``static/index.html``, ``app.js``, ``style.css``) is package
data: plain SVG and JavaScript, no CDN, so it works offline.
"""

from __future__ import annotations

import argparse

from gcs.adapters.web.server import DEFAULT_HTTP, LiveMapServer, parse_http_address

__all__ = ["DEFAULT_HTTP", "LiveMapServer", "parse_http_address", "add_http_argument"]


def _http_type(text: str) -> tuple[str, int] | None:
    try:
        return parse_http_address(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_http_argument(parser: argparse.ArgumentParser, what: str = "the live map") -> None:
    """``--http ADDRESS`` (default :data:`DEFAULT_HTTP`; ``none`` disables; port 0 picks a free port)."""
    parser.add_argument("--http", type=_http_type, default=parse_http_address(DEFAULT_HTTP), metavar="ADDRESS",
                        help=f"serve {what} at http://ADDRESS/ (default {DEFAULT_HTTP}; port 0 picks a free port; "
                             "none: no page)")
