"""``~/get_type_description``: a node tells others the full definition of a type it uses.

Counterparts: rclpy's ``rclpy.type_description_service.TypeDescriptionService`` (the node's
read-only ``start_type_description_service`` parameter, default true, switches it on) and
rcl's ``rcl_node_type_description_service_handle_request`` (Jazzy and newer). Request
``type_description_interfaces/srv/GetTypeDescription``: ``type_name``, ``type_hash``
(``RIHS01_<64 hex>``), ``include_type_sources``. As rcl: the type is looked up by its hash
among the types the node uses now (its publishers, subscriptions, services and clients,
actions included through theirs); a hash that does not parse fails with "Failed to parse type
hash", an unknown one with "Type not currently in use by this node".

Differences from rcl: ``Field.default_value`` holds the default as written in our .msg text
(rosidl renders it from the IDL); ``type_sources`` carry our definition texts (encoding
``msg`` / ``srv`` / ``action``), which have the upstream fields but not the upstream files'
comments, so their bytes differ from the files a ROS 2 install holds.
"""

from __future__ import annotations

import re
import weakref

from robocourse.bus.parameters import Parameter, ParameterDescriptor, ParameterType
from robocourse.msgs._core import REGISTRY
from robocourse.msgs.type_description_interfaces import (
    Field,
    FieldType,
    GetTypeDescription,
    IndividualTypeDescription,
    TypeDescription,
    TypeSource,
)

START_TYPE_DESCRIPTION_SERVICE_PARAM = "start_type_description_service"
_HASH = re.compile(r"^RIHS01_[0-9a-fA-F]{64}$")


def node_types(node) -> dict[str, type]:
    """``{RIHS01 hash: type}`` of every message and service type ``node`` uses now (what rcl's
    node type cache holds: registered as entities are created, dropped with the last one)."""
    from robocourse.bus.zenoh.wire import type_hash

    types = [p.msg_type for p in node.publishers] + [s.msg_type for s in node.subscriptions]
    rosout = getattr(node, "_rosout_publisher", None)
    if rosout is not None:
        types.append(rosout.msg_type)
    types += [s.srv_type for s in node.services] + [c.srv_type for c in node.clients]
    return {type_hash(t): t for t in types}


def _individual(desc: dict) -> IndividualTypeDescription:
    t = REGISTRY.get(desc["type_name"])
    defaults = {s.name: s.default_text.strip() for s in getattr(t, "_fields", ())
                if s.default_text is not None}
    return IndividualTypeDescription(type_name=desc["type_name"], fields=[
        Field(name=f["name"], type=FieldType(**f["type"]),
              default_value=defaults.get(f["name"], "")) for f in desc["fields"]])


def type_description_msg(t) -> TypeDescription:
    """``t``'s TypeDescription message: the REP-2011 description its hash is computed from,
    with default values filled in."""
    from robocourse.bus.zenoh.wire import type_description

    d = type_description(t)
    return TypeDescription(type_description=_individual(d["type_description"]),
                           referenced_type_descriptions=[
                               _individual(r) for r in d["referenced_type_descriptions"]])


def type_sources(t) -> list[TypeSource]:
    """The definition texts of ``t`` and every type it references (rosidl's type sources)."""
    from robocourse.bus.zenoh.wire import type_description

    names = [t._type] + [r["type_name"] for r in type_description(t)["referenced_type_descriptions"]]
    out = []
    for name in names:
        known = t if name == t._type else REGISTRY.get(name)
        if known is None:
            continue
        kind = name.split("/")[1] if name.count("/") == 2 else "msg"
        out.append(TypeSource(type_name=name, encoding=kind,
                              raw_file_contents=getattr(known, "_definition", "") or ""))
    return out


class TypeDescriptionService:
    """rclpy.type_description_service.TypeDescriptionService for one node."""

    def __init__(self, node):
        self._node_ref = weakref.ref(node)
        self.service_name = f"{node.get_name()}/get_type_description"
        self.service = None
        if not node.has_parameter(START_TYPE_DESCRIPTION_SERVICE_PARAM):
            node.declare_parameter(START_TYPE_DESCRIPTION_SERVICE_PARAM, True, ParameterDescriptor(
                type=int(ParameterType.BOOL), read_only=True,
                description="If enabled, start the ~/get_type_description service."))
        param = node.get_parameter(START_TYPE_DESCRIPTION_SERVICE_PARAM)
        self.enabled = param.type_ == Parameter.Type.BOOL and bool(param.value)
        if param.type_ not in (Parameter.Type.BOOL, Parameter.Type.NOT_SET):
            node.get_logger().error(
                f"Invalid type for parameter '{START_TYPE_DESCRIPTION_SERVICE_PARAM}' "
                f"{param.type_!r} should be bool")
        if self.enabled:
            self.service = node.create_service(GetTypeDescription, self.service_name,
                                               self._handle, _builtin=True)

    def _handle(self, request, response):
        response.successful = False
        if not _HASH.match(request.type_hash):
            response.failure_reason = "Failed to parse type hash"
            return response
        node = self._node_ref()
        t = node_types(node).get("RIHS01_" + request.type_hash[7:].lower()) if node is not None else None
        if t is None:
            response.failure_reason = "Type not currently in use by this node"
            return response
        response.type_description = type_description_msg(t)
        if request.include_type_sources:
            response.type_sources = type_sources(t)
        response.successful = True
        return response

    def destroy(self) -> None:
        node = self._node_ref()
        if node is not None and self.service is not None:
            node.destroy_service(self.service)
        self.service = None
