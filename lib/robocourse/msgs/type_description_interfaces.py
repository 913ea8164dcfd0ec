"""type_description_interfaces: what a Jazzy node's ``~/get_type_description`` service answers.

Field lists as in ros2/rcl_interfaces (``type_description_interfaces``, Jazzy):
``msg/FieldType``, ``msg/Field``, ``msg/IndividualTypeDescription``, ``msg/TypeDescription``,
``msg/TypeSource``, ``msg/KeyValue`` and ``srv/GetTypeDescription``. A TypeDescription is the
structure REP-2011 hashes into a ``RIHS01_`` type hash (robocourse.bus.zenoh.wire).
"""

from robocourse.msgs._core import message, service

# FieldType ids (REP-2011): scalars 0..22; a fixed array adds 48, a bounded sequence 96, an
# unbounded sequence 144.
_SCALARS = ["NESTED_TYPE", "INT8", "UINT8", "INT16", "UINT16", "INT32", "UINT32", "INT64",
            "UINT64", "FLOAT", "DOUBLE", "LONG_DOUBLE", "CHAR", "WCHAR", "BOOLEAN", "BYTE",
            "STRING", "WSTRING", "FIXED_STRING", "FIXED_WSTRING", "BOUNDED_STRING",
            "BOUNDED_WSTRING"]
_CONSTANTS = ["uint8 FIELD_TYPE_NOT_SET = 0"]
for _offset, _suffix in ((0, ""), (48, "_ARRAY"), (96, "_BOUNDED_SEQUENCE"),
                         (144, "_UNBOUNDED_SEQUENCE")):
    _CONSTANTS += [f"uint8 FIELD_TYPE_{n}{_suffix} = {i + 1 + _offset}"
                   for i, n in enumerate(_SCALARS)]


@message("type_description_interfaces/msg/FieldType", "\n".join(_CONSTANTS) + """
uint8 type_id 0
uint64 capacity          # array size or sequence bound (0: unbounded)
uint64 string_capacity   # string bound (0: unbounded)
string<=255 nested_type_name
""")
class FieldType:
    pass


@message("type_description_interfaces/msg/Field", """
string name
FieldType type
string default_value
""")
class Field:
    pass


@message("type_description_interfaces/msg/IndividualTypeDescription", """
string<=255 type_name
Field[] fields
""")
class IndividualTypeDescription:
    pass


@message("type_description_interfaces/msg/TypeDescription", """
IndividualTypeDescription type_description
IndividualTypeDescription[] referenced_type_descriptions
""")
class TypeDescription:
    pass


@message("type_description_interfaces/msg/TypeSource", """
string type_name
string encoding            # msg, srv, action, idl, or empty
string raw_file_contents
""")
class TypeSource:
    pass


@message("type_description_interfaces/msg/KeyValue", """
string key
string value
""")
class KeyValue:
    pass


GetTypeDescription = service("type_description_interfaces/srv/GetTypeDescription", """
string type_name
string type_hash
bool include_type_sources true
---
bool successful
string failure_reason
TypeDescription type_description
TypeSource[] type_sources
KeyValue[] extra_information
""")

__all__ = ["Field", "FieldType", "GetTypeDescription", "IndividualTypeDescription", "KeyValue",
           "TypeDescription", "TypeSource"]
