"""std_srvs: Empty, Trigger and SetBool services."""

from __future__ import annotations

from robotrial.msgs.core import Message, bool_, message, service, string


@message("std_srvs/srv/Empty_Request")
class EmptyRequest(Message):
    pass


@message("std_srvs/srv/Empty_Response")
class EmptyResponse(Message):
    pass


@message("std_srvs/srv/Trigger_Request")
class TriggerRequest(Message):
    pass


@message("std_srvs/srv/Trigger_Response")
class TriggerResponse(Message):
    success: bool_
    message: string


@message("std_srvs/srv/SetBool_Request")
class SetBoolRequest(Message):
    data: bool_


@message("std_srvs/srv/SetBool_Response")
class SetBoolResponse(Message):
    success: bool_
    message: string


Empty = service("std_srvs/srv/Empty", EmptyRequest, EmptyResponse)
Trigger = service("std_srvs/srv/Trigger", TriggerRequest, TriggerResponse)
SetBool = service("std_srvs/srv/SetBool", SetBoolRequest, SetBoolResponse)
