"""Device URLs (``socket://HOST:PORT``, ``ur://HOST``, ``emscon://HOST[:PORT]``): one parser.

Every driver that takes a URL reads it here first, so a malformed one is
refused with one line naming what is wrong, before a transport library sees
it (pyserial reports a missing port as ``'<=' not supported between
instances of 'int' and 'NoneType'`` and a port above 65535 as
``'debug|info|warning|error'``)::

    'socket://': missing host (use socket://HOST:PORT)
    'socket://127.0.0.1:99999': port 99999 is out of 1..65535
    'socket://h:5000?foo=1': unknown parameter 'foo' (socket:// takes logging)

Use::

    from drivers import urls

    where = urls.parse(url, "socket", port="required", params={"logging": urls.LOGGING})
    where.host, where.port, where.params       # "127.0.0.1", 5000, {}

Errors are :class:`ValueError` (what the tracker and robot registries raise
for a URL that does not suit its kind).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Literal
from urllib.parse import parse_qsl, urlsplit

__all__ = ["LOGGING", "Address", "parse", "settings"]

#: A DNS name or an IPv4 address (IPv6 literals come out of urlsplit without brackets).
_HOST = re.compile(r"[A-Za-z0-9](?:[A-Za-z0-9.-]{0,252})|[0-9A-Fa-f:.]*:[0-9A-Fa-f:.]*")
#: pyserial's ``logging=`` levels.
LOGGING = ("debug", "info", "warning", "error")


@dataclass(frozen=True)
class Address:
    """A parsed device URL.

    Attributes
    ----------
    scheme : str
        Lower case, without ``://``.
    host : str
    port : int or None
        None when the URL gives none and the kind has no default.
    params : dict of str to str
        The query's ``name=value`` pairs.
    """

    scheme: str
    host: str
    port: int | None
    params: dict[str, str] = field(default_factory=dict)


def parse(
    url: str,
    scheme: str,
    *,
    port: Literal["required", "optional", "none"] = "optional",
    default_port: int | None = None,
    host: bool = True,
    params: Mapping[str, tuple[str, ...] | Callable[[str], object] | None] | None = None,
) -> Address:
    """Split a device URL and check each part.

    Parameters
    ----------
    url : str
    scheme : str
        The scheme the URL must have (``"socket"``).
    port : {'required', 'optional', 'none'}
        Whether the URL must, may or must not give a port.
    default_port : int, optional
        The port when the URL gives none (``port="optional"``).
    host : bool
        Whether the URL names a host (``loop://`` names none).
    params : mapping, optional
        Allowed query parameters: name -> allowed values (a tuple), a check
        (``check(value)`` raising ValueError), or None (any value). None:
        the URL takes no parameters.

    Returns
    -------
    Address

    Raises
    ------
    ValueError
        One line starting with the URL: another scheme, a missing or
        malformed host, a missing, malformed, unwanted or out-of-range port
        (1..65535), a path, an unknown or repeated parameter or a value it
        does not take.
    """
    text = str(url)
    example = f"{scheme}://HOST" + {"required": ":PORT", "optional": "[:PORT]", "none": ""}[port]
    if not host:
        example = f"{scheme}://"
    if len(text) > 512 or not text.isprintable() or " " in text:
        raise ValueError(f"{_shown(text)}: not a URL (use {example})")
    try:
        parts = urlsplit(text)
    except ValueError as exc:  # a bracketed host that is no IPv6 address
        raise ValueError(f"{_shown(text)}: not a URL ({exc})") from None
    if parts.scheme.lower() != scheme:
        raise ValueError(f"{_shown(text)}: expected {example}")
    netloc = parts.netloc
    if "@" in netloc:
        raise ValueError(f"{_shown(text)}: user names are not taken (use {example})")
    if not host:
        if netloc:
            raise ValueError(f"{_shown(text)}: {scheme}:// takes no host (use {example})")
        return Address(scheme, "", None, _params(text, parts.query, scheme, params))
    # As written (urlsplit's hostname is lower case; a journal records the host).
    if netloc.startswith("["):
        name = netloc[1:].split("]", 1)[0]
    else:
        name = netloc.rsplit(":", 1)[0] if ":" in netloc else netloc
    if not name:
        raise ValueError(f"{_shown(text)}: missing host (use {example})")
    if not _HOST.fullmatch(name):
        raise ValueError(f"{_shown(text)}: {name!r} is not a host name or address")
    number = _port(text, netloc)
    if number is None and port == "required":
        raise ValueError(f"{_shown(text)}: missing port (use {example})")
    if number is not None and port == "none":
        raise ValueError(f"{_shown(text)}: {scheme}:// takes no port (use {example})")
    if parts.path not in ("", "/") or parts.fragment:
        raise ValueError(f"{_shown(text)}: unexpected path {parts.path or parts.fragment!r}")
    query = _params(text, parts.query, scheme, params)
    return Address(scheme, name, number if number is not None else default_port, query)


def settings(
    url: str,
    scheme: str,
    params: Mapping[str, tuple[str, ...] | Callable[[str], object] | None],
) -> dict[str, str]:
    """The query of a kind with no host, named bare (``sim``) or configured (``sim://?noise=off``).

    Parameters
    ----------
    url : str
    scheme : str
        The kind: the bare word, and the URL's scheme.
    params : mapping
        Allowed query parameters, as :func:`parse` takes them.

    Returns
    -------
    dict of str to str
        Empty for the bare word.

    Raises
    ------
    ValueError
        As :func:`parse`: another scheme, a host, an unknown parameter or value.
    """
    if str(url).lower() == scheme:
        return {}
    return parse(url, scheme, host=False, params=params).params


def _port(text: str, netloc: str) -> int | None:
    """The port of ``host:port`` / ``[v6]:port``, or None; checked as digits in 1..65535."""
    rest = netloc.rsplit("]", 1)[1] if netloc.startswith("[") else netloc
    if ":" not in rest:
        return None
    digits = rest.rsplit(":", 1)[1]
    if not digits:
        raise ValueError(f"{_shown(text)}: empty port after ':'")
    if not digits.isascii() or not digits.isdigit():
        raise ValueError(f"{_shown(text)}: port {digits!r:.20} is not a number")
    value = int(digits[:6]) if len(digits) <= 6 else 10**6
    if not 1 <= value <= 65535:
        raise ValueError(f"{_shown(text)}: port {digits:.12} is out of 1..65535")
    return value


def _params(
    text: str,
    query: str,
    scheme: str,
    allowed: Mapping[str, tuple[str, ...] | Callable[[str], object] | None] | None,
) -> dict[str, str]:
    if not query:
        return {}
    if not allowed:
        raise ValueError(f"{_shown(text)}: {scheme}:// takes no parameters")
    known = ", ".join(sorted(allowed))
    try:
        pairs = parse_qsl(query, keep_blank_values=True, strict_parsing=True)
    except ValueError:
        raise ValueError(
            f"{_shown(text)}: parameters must be name=value (known: {known})"
        ) from None
    names = [name for name, _ in pairs]
    twice = next((name for name in names if names.count(name) > 1 and name in allowed), None)
    if twice is not None:
        raise ValueError(f"{_shown(text)}: parameter {twice!r} given twice")
    out: dict[str, str] = {}
    for name, value in pairs:
        if name not in allowed:
            raise ValueError(
                f"{_shown(text)}: unknown parameter {name!r:.30} ({scheme}:// takes {known})"
            )
        rule = allowed[name]
        if isinstance(rule, tuple) and value not in rule:
            raise ValueError(
                f"{_shown(text)}: {name}={value!r:.30} is not one of {', '.join(rule)}"
            )
        if callable(rule):
            try:
                rule(value)
            except ValueError as exc:  # its message names the parameter
                raise ValueError(f"{_shown(text)}: {exc}") from None
        out[name] = value
    return out


def _shown(text: str) -> str:
    return repr(text if len(text) <= 80 else text[:77] + "...")
