# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The node's parameter services, guarded: whatever a client sends, a refusal, not the node's end.

rclpy's parameter services raise out of the executor on some requests (a parameter type number
that is no type), and that ended the node. Each request they cannot handle is refused here in
its response (an empty answer to a query), with one throttled warning.
"""

from collections.abc import Callable

from rcl_interfaces.msg import SetParametersResult
from rcl_interfaces.srv import (DescribeParameters, GetParameters, GetParameterTypes,
                                ListParameters, SetParameters, SetParametersAtomically)

from .character import throttled


def guard_parameter_services(node: 'object', log_times: dict) -> None:
    """Wrap the callback of each of ``node``'s parameter services (rclpy's ParameterService).

    :param node: the rclpy node whose parameter services are wrapped.
    :param log_times: the node's throttled warnings (ros/character.py's ``throttled``).
    """
    kinds = (DescribeParameters, GetParameters, GetParameterTypes, ListParameters,
             SetParameters, SetParametersAtomically)
    for service in node.services:
        if service.srv_type in kinds:
            service.callback = _guarded(service.callback, service.srv_type, node, log_times)


def _guarded(callback: Callable, srv_type: type, node: 'object', log_times: dict) -> Callable:
    def refused(e):
        reason = f'request refused: {type(e).__name__}: {str(e)[:200]}'
        throttled(node.get_logger(), log_times, 'parameter_service',
                  f'a {srv_type.__name__} {reason}')
        return SetParametersResult(successful=False, reason=reason)

    def call(request, response):
        if srv_type is SetParameters:
            # One at a time, as rclpy sets them: a bad one after good ones, which are set,
            # is refused alone.
            for p in request.parameters:
                try:
                    result, = callback(SetParameters.Request(parameters=[p]),
                                       SetParameters.Response()).results
                except Exception as e:  # noqa: BLE001 - whatever a request does, the node goes on
                    result = refused(e)
                response.results.append(result)
            return response
        try:
            return callback(request, response)
        except Exception as e:  # noqa: BLE001 - as above; rclpy reads them all before any is set
            result = refused(e)
            response = srv_type.Response()
            if srv_type is SetParametersAtomically:
                response.result = result
            return response
    return call
