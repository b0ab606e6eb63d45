"""ROS 2 name rules: validation, namespaces, ``~`` expansion and remapping."""

from __future__ import annotations

import hashlib
import re
from collections.abc import Mapping

from runtime.errors import InvalidNameError

_TOKEN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def validate_node_name(name: str) -> str:
    if not _TOKEN.match(name):
        raise InvalidNameError(
            f"invalid node name {name!r}: use letters, digits and '_', not starting with a digit"
        )
    return name


def validate_namespace(namespace: str) -> str:
    if namespace in ("", "/"):
        return "/"
    ns = namespace if namespace.startswith("/") else f"/{namespace}"
    ns = ns.rstrip("/")
    for token in ns.split("/")[1:]:
        if not _TOKEN.match(token):
            raise InvalidNameError(f"invalid namespace {namespace!r}: bad token {token!r}")
    return ns


def resolve_name(
    name: str,
    namespace: str,
    node_name: str,
    remappings: Mapping[str, str] | None = None,
) -> str:
    """The fully qualified name of a topic, service or action as a node sees it.

    ``chatter`` resolves under the node's namespace, ``/chatter`` is absolute, ``~/x`` is
    private to the node. A remapping may name the name as written or as resolved.
    """
    if not name:
        raise InvalidNameError("empty topic/service name")
    remappings = remappings or {}
    if name in remappings:
        name = remappings[name]
    ns = validate_namespace(namespace)
    if name.startswith("~"):
        base = f"{ns.rstrip('/')}/{node_name}"
        resolved = base + name[1:] if name != "~" else base
    elif name.startswith("/"):
        resolved = name
    else:
        resolved = f"{ns.rstrip('/')}/{name}"
    if resolved in remappings:
        resolved = remappings[resolved]
        if not resolved.startswith("/"):
            resolved = f"{ns.rstrip('/')}/{resolved}"
    tokens = resolved.split("/")[1:]
    if resolved.endswith("/") or not tokens or any(not _TOKEN.match(t) for t in tokens):
        raise InvalidNameError(
            f"invalid name {name!r} (resolved {resolved!r}): tokens are letters, digits and "
            "'_', separated by single '/', not starting with a digit"
        )
    return resolved


def stable_guid(*parts: str) -> int:
    """A 64-bit identifier derived from names, the same in every run (for determinism)."""
    digest = hashlib.blake2b("/".join(parts).encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little")

