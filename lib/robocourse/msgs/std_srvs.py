"""std_srvs: Empty, Trigger, SetBool."""

from robocourse.msgs._core import service

Empty = service("std_srvs/srv/Empty", "---")
Trigger = service("std_srvs/srv/Trigger", """
---
bool success   # indicate successful run of triggered service
string message # informational, e.g. for error messages
""")
SetBool = service("std_srvs/srv/SetBool", """
bool data # e.g. for hardware enabling / disabling
---
bool success   # indicate successful run of triggered service
string message # informational, e.g. for error messages
""")

__all__ = ["Empty", "Trigger", "SetBool"]
