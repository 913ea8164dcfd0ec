"""The six parameter services every node serves, as ``ros2 param`` expects them.

rclpy counterpart: ``rclpy.parameter_service.ParameterService`` (started by
``Node(start_parameter_services=True)``, the default). Services, relative to the node
(``/<namespace>/<node>/...``), all with ``qos_profile_parameters``:

=============================  ===========================================  =================
service                        type                                         ``ros2 param``
=============================  ===========================================  =================
``~/describe_parameters``      ``rcl_interfaces/srv/DescribeParameters``     ``describe``
``~/get_parameter_types``      ``rcl_interfaces/srv/GetParameterTypes``      (``dump``)
``~/get_parameters``           ``rcl_interfaces/srv/GetParameters``          ``get``
``~/list_parameters``          ``rcl_interfaces/srv/ListParameters``         ``list``
``~/set_parameters``           ``rcl_interfaces/srv/SetParameters``          ``set``
``~/set_parameters_atomically````rcl_interfaces/srv/SetParametersAtomically`` (``load``)
=============================  ===========================================  =================

Replies as rclpy's: a request naming one undeclared (or uninitialized) parameter gets an
empty list back for describe/get/get_types; a set of an undeclared parameter fails with the
exception's text as the reason. Over the zenoh transport these are ordinary queryables, so a
``ros2 param list`` on a machine running rmw_zenoh reaches them.
"""

from __future__ import annotations

import weakref

from robocourse.bus.parameters import (
    Parameter,
    ParameterNotDeclaredException,
    ParameterUninitializedException,
)
from robocourse.bus.qos import qos_profile_parameters
from robocourse.msgs.rcl_interfaces import (
    DescribeParameters,
    GetParameters,
    GetParameterTypes,
    ListParameters,
    ListParametersResult,
    SetParameters,
    SetParametersAtomically,
    SetParametersResult,
)

#: (name relative to the node, type, handler method) in the order rclpy creates them
SERVICES = (
    ("describe_parameters", DescribeParameters, "_describe"),
    ("get_parameters", GetParameters, "_get"),
    ("get_parameter_types", GetParameterTypes, "_get_types"),
    ("list_parameters", ListParameters, "_list"),
    ("set_parameters", SetParameters, "_set"),
    ("set_parameters_atomically", SetParametersAtomically, "_set_atomically"),
)


class ParameterService:
    """rclpy.parameter_service.ParameterService: the six services of one node."""

    def __init__(self, node):
        self._node_ref = weakref.ref(node)
        name = node.get_name()
        self.services = [
            node.create_service(srv_type, f"{name}/{suffix}", getattr(self, handler),
                                qos_profile=qos_profile_parameters, _builtin=True)
            for suffix, srv_type, handler in SERVICES]

    def _node(self):
        node = self._node_ref()
        if node is None:
            raise ReferenceError("the node of this parameter service was destroyed")
        return node

    def _describe(self, request, response):
        node = self._node()
        for name in request.names:
            try:
                response.descriptors.append(node.describe_parameter(name))
            except ParameterNotDeclaredException:
                response.descriptors = []
                return response
        return response

    def _get(self, request, response):
        node = self._node()
        for name in request.names:
            try:
                response.values.append(node.get_parameter(name).get_parameter_value())
            except (ParameterNotDeclaredException, ParameterUninitializedException):
                response.values = []
                return response
        return response

    def _get_types(self, request, response):
        node = self._node()
        for name in request.names:
            try:
                response.types.append(int(node.get_parameter_type(name)))
            except ParameterNotDeclaredException:
                response.types = []
                return response
        return response

    def _list(self, request, response):
        try:
            response.result = self._node().list_parameters(list(request.prefixes),
                                                           int(request.depth))
        except (TypeError, ValueError):
            response.result = ListParametersResult()
        return response

    def _set(self, request, response):
        node = self._node()
        for p in request.parameters:
            try:
                result = node.set_parameters_atomically([Parameter.from_parameter_msg(p)])
            except ParameterNotDeclaredException as exc:
                result = SetParametersResult(successful=False, reason=str(exc))
            response.results.append(result)
        return response

    def _set_atomically(self, request, response):
        try:
            response.result = self._node().set_parameters_atomically(
                [Parameter.from_parameter_msg(p) for p in request.parameters])
        except ParameterNotDeclaredException as exc:
            response.result = SetParametersResult(successful=False, reason=str(exc))
        return response

    def destroy(self) -> None:
        node = self._node_ref()
        if node is not None:
            for srv in self.services:
                node.destroy_service(srv)
        self.services = []
