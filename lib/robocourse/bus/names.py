"""ROS 2 naming rules for nodes, namespaces, topics and services, and name expansion.

rclpy counterpart: ``rclpy.validate_node_name``, ``validate_namespace``, ``validate_topic_name``
and ``rclpy.expand_topic_name`` (rcl's ``rcl_expand_topic_name``). Substitutions other than
``~`` (``{node}``, ``{ns}``) are accepted and expanded the same way.
"""

from __future__ import annotations

import re


class InvalidNameError(ValueError):
    """A node, namespace, topic or service name that breaks the ROS 2 rules."""


class InvalidNodeNameException(InvalidNameError):
    pass


class InvalidNamespaceException(InvalidNameError):
    pass


class InvalidTopicNameException(InvalidNameError):
    pass


class InvalidServiceNameException(InvalidNameError):
    pass


_NODE_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_TOKEN_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_SUBST_RE = re.compile(r"\{[A-Za-z_][A-Za-z0-9_]*\}")
MAX_NAME_LENGTH = 255


def validate_node_name(name: str) -> str:
    if not isinstance(name, str) or not name:
        raise InvalidNodeNameException(f"node name must be a non-empty string, got {name!r}")
    if len(name) > MAX_NAME_LENGTH:
        raise InvalidNodeNameException(f"node name {name!r} is longer than {MAX_NAME_LENGTH} characters")
    if name[0].isdigit():
        raise InvalidNodeNameException(
            f"node name {name!r} must not start with a number; e.g. 'node_{name}'")
    if not _NODE_RE.match(name):
        bad = next(c for c in name if not (c.isalnum() or c == "_"))
        raise InvalidNodeNameException(
            f"node name {name!r} contains {bad!r}: node names may only contain letters, digits "
            f"and '_' (no '/', put that part in the namespace)")
    return name


def validate_namespace(namespace: str) -> str:
    if not isinstance(namespace, str) or not namespace:
        raise InvalidNamespaceException(f"namespace must be a non-empty string, got {namespace!r}")
    if namespace[0] != "/":
        raise InvalidNamespaceException(
            f"namespace {namespace!r} must be absolute (start with '/'); e.g. '/{namespace}'")
    if namespace == "/":
        return namespace
    if namespace.endswith("/"):
        raise InvalidNamespaceException(f"namespace {namespace!r} must not end with '/'")
    for token in namespace[1:].split("/"):
        _check_token(token, namespace, "namespace", InvalidNamespaceException)
    return namespace


def _check_token(token: str, whole: str, what: str, exc):
    if token == "":
        raise exc(f"{what} {whole!r} contains '//' (an empty token)")
    if token[0].isdigit():
        raise exc(f"{what} {whole!r}: token {token!r} must not start with a number")
    if not _TOKEN_RE.match(_SUBST_RE.sub("x", token)):
        bad = next((c for c in token if not (c.isalnum() or c in "_{}")), token)
        raise exc(f"{what} {whole!r}: token {token!r} contains {bad!r}; use letters, digits, '_'")


def validate_topic_name(name: str, *, is_service: bool = False) -> str:
    """Check a (possibly relative, possibly ``~``) topic or service name."""
    what = "service name" if is_service else "topic name"
    exc = InvalidServiceNameException if is_service else InvalidTopicNameException
    if not isinstance(name, str) or not name:
        raise exc(f"{what} must be a non-empty string, got {name!r}")
    if name.endswith("/") and name != "/":
        raise exc(f"{what} {name!r} must not end with '/'")
    if name == "/":
        raise exc(f"{what} '/' is not a valid name")
    if "~" in name[1:]:
        raise exc(f"{what} {name!r}: '~' is only allowed at the start ('~' or '~/...')")
    if name[0] == "~" and len(name) > 1 and name[1] != "/":
        raise exc(f"{what} {name!r}: '~' must be followed by '/' (e.g. '~/{name[1:]}')")
    body = name.lstrip("~").lstrip("/") if name[0] in "~/" else name
    if name.startswith("~"):
        body = name[2:] if len(name) > 1 else ""
    if body:
        for token in body.split("/"):
            _check_token(token, name, what, exc)
    return name


def expand_topic_name(name: str, node_name: str, namespace: str, *, is_service: bool = False) -> str:
    """Resolve a name like rcl: absolute stays, ``~`` is ``<ns>/<node>``, relative gets ``<ns>/``."""
    validate_topic_name(name, is_service=is_service)
    ns = namespace if namespace != "/" else ""
    if name.startswith("~"):
        name = f"{ns}/{node_name}" + name[1:]
    elif not name.startswith("/"):
        name = f"{ns}/{name}"
    name = name.replace("{node}", node_name).replace("{ns}", ns or "/").replace("{namespace}", ns or "/")
    name = re.sub(r"/+", "/", name)
    exc = InvalidServiceNameException if is_service else InvalidTopicNameException
    if _SUBST_RE.search(name):
        raise exc(f"unknown substitution in {name!r}: only {{node}} and {{ns}} are known")
    return name


def normalize_namespace(namespace: str | None) -> str:
    if namespace is None or namespace == "":
        return "/"
    if not namespace.startswith("/"):
        namespace = "/" + namespace
    return validate_namespace(namespace)


def fully_qualified_node_name(name: str, namespace: str) -> str:
    return (namespace.rstrip("/") + "/" + name) if namespace != "/" else "/" + name
