"""robocourse.control.parameters: generate_parameter_library schemas, RSL validator texts, YAML files."""

from __future__ import annotations

import pytest

from robocourse.bus import InvalidParameterValueException
from robocourse.control.parameters import (
    InvalidParameterTypeException,
    ParameterSchema,
    ParameterUninitializedException,
    ParamListener,
    SchemaError,
    load_parameter_file,
    params_for,
)


def schema(body: str) -> ParameterSchema:
    return ParameterSchema.from_yaml("ns:\n" + "\n".join("  " + line for line in body.strip().splitlines()))


def init_error(body: str, values: dict) -> str:
    with pytest.raises(InvalidParameterValueException) as err:
        ParamListener(schema(body), values)
    return str(err.value).split("Reason: ", 1)[1]


@pytest.mark.parametrize("validation, value, message", [
    ("gt<>: [0.0]", 0.0, "Parameter 'x' with the value '0' must be greater than '0'"),
    ("gt_eq<>: [0.1]", 0.05, "Parameter 'x' with the value '0.05' must be greater than or equal to '0.1'"),
    ("lt<>: [1.0]", 1.5, "Parameter 'x' with the value '1.5' must be less than '1'"),
    ("lt_eq<>: [1.0]", 1.5, "Parameter 'x' with the value '1.5' must be less than or equal to '1'"),
    ("bounds<>: [0.0, 1.0]", 2.5, "Parameter 'x' with the value '2.5' must be within bounds '[0, 1]'"),
])
def test_scalar_validators_use_rsl_texts(validation, value, message):
    body = f"x: {{type: double, default_value: 0.5, validation: {{{validation}}}}}"
    if validation.startswith("gt<>") or validation.startswith("gt_eq"):
        body = f"x: {{type: double, default_value: 1.0, validation: {{{validation}}}}}"
    assert init_error(body, {"x": value}) == f"Invalid value set during initialization for parameter 'x': {message}"


@pytest.mark.parametrize("ptype, validation, value, message", [
    ("string", 'one_of<>: [["a", "b"]]', "c", "Parameter 'x' with the value 'c' is not in the set '{a, b}'"),
    ("string", "not_empty<>: null", "", "Parameter 'x' cannot be empty"),
    ("string_array", "unique<>: null", ["a", "a"], "Parameter 'x' must only contain unique values"),
    ("string_array", 'subset_of<>: [["a", "b"]]', ["a", "z"], "Entry 'z' in parameter 'x' is not in the set '{a, b}'"),
    ("double_array", "fixed_size<>: [3]", [1.0], "Length of parameter 'x' is '1' but must be equal to '3'"),
    ("double_array", "size_gt<>: [1]", [1.0], "Length of parameter 'x' is '1' but must be greater than '1'"),
    ("double_array", "size_lt<>: [2]", [1.0, 2.0], "Length of parameter 'x' is '2' but must be less than '2'"),
    ("double_array", "element_bounds<>: [0.0, 1.0]", [0.5, 3.0],
     "Value '3' in parameter 'x' must be within bounds '[0, 1]'"),
    ("double_array", "lower_element_bounds<>: [0.0]", [-1.0], "Value '-1' in parameter 'x' must be above lower bound of '0'"),
    ("double_array", "upper_element_bounds<>: [1.0]", [2.0], "Value '2' in parameter 'x' must be below upper bound of '1'"),
])
def test_collection_validators_use_rsl_texts(ptype, validation, value, message):
    body = f"x: {{type: {ptype}, validation: {{{validation}}}}}"
    assert init_error(body, {"x": value}).endswith(message)


def test_defaults_mandatory_and_types():
    s = schema("""
rate: {type: double, default_value: 20}
joints: {type: string_array}
flag: {type: bool, default_value: false}
name: {type: string_fixed_5, default_value: "abc"}
""")
    p = ParamListener(s, {"joints": ["j1"]}).get_params()
    assert (p.rate, p.joints, p.flag, p.name) == (20.0, ["j1"], False, "abc")
    with pytest.raises(ParameterUninitializedException, match="parameter 'joints' is not initialized"):
        ParamListener(s, {})
    with pytest.raises(InvalidParameterTypeException, match=r"parameter \{rate\} is of type \{double\}, setting it "
                                                            r"to \{integer\} is not allowed"):
        ParamListener(s, {"joints": ["j1"], "rate": 5})
    with pytest.raises(InvalidParameterTypeException, match=r"setting it to \{string\}"):
        ParamListener(s, {"joints": "j1"})
    with pytest.raises(InvalidParameterValueException, match="Length of parameter 'name' is '7' but must be less "
                                                             "than '6'"):
        ParamListener(s, {"joints": ["j1"], "name": "toolong"})


@pytest.mark.parametrize("text, message", [
    ("a: {x: {type: int}}\nb: {y: {type: int}}", "The yaml definition must only have one root element"),
    ("ns:\n  x: {default_value: 1}", "No type defined for parameter x"),
    ("ns:\n  x: {type: int, colour: red}", "Invalid syntax in parameter x. 'colour' is not valid syntax"),
    ("ns:\n  x: {type: float}", "Invalid parameter type `float` for parameter x. Allowed types are:"),
    ("ns:\n  x: {type: int, default_value: 1.5}", "Parameter x has incorrect type. Expected: int, got: double"),
    ("ns:\n  x: {type: double, validation: {bounds<>: [0, 1], gt<>: [0]}}",
     "Parameter x cannot combine 'bounds' with scalar bound validators (gt/gt_eq/lt/lt_eq)."),
])
def test_schema_errors_at_definition(text, message):
    with pytest.raises(SchemaError) as err:
        ParameterSchema.from_yaml(text)
    assert str(err.value).startswith(message)


def test_map_entries_nested_structs_and_unused_keys():
    s = schema("""
joints: {type: string_array}
gains:
  __map_joints:
    p: {type: double, default_value: 0.0, validation: {gt_eq<>: [0.0]}}
    i: {type: double, default_value: 0.0}
constraints:
  goal_time: {type: double, default_value: 0.0}
""")
    listener = ParamListener(s, {"joints": ["shoulder", "elbow"], "gains.elbow.p": 2.5, "gians.elbow.i": 1.0})
    p = listener.get_params()
    assert (p.gains.get_entry("shoulder").p, p.gains.elbow.p, p.constraints.goal_time) == (0.0, 2.5, 0.0)
    assert listener.unused == ["gians.elbow.i"]
    with pytest.raises(InvalidParameterValueException, match="Parameter 'gains.elbow.p' with the value '-1'"):
        ParamListener(s, {"joints": ["elbow"], "gains.elbow.p": -1.0})


def test_runtime_update_validated_read_only_refused_and_rt_swap():
    s = schema("""
joints: {type: string_array, read_only: true}
rate: {type: double, default_value: 20.0, validation: {gt_eq<>: [0.1]}}
""")
    listener = ParamListener(s, {"joints": ["j1"]})
    rt = listener.get_params()
    assert listener.set("joints", ["j2"]).reason == "parameter 'joints' cannot be set because it is read-only"
    assert listener.set("rate", 0.0).reason == "Parameter 'rate' with the value '0' must be greater than or equal to '0.1'"
    assert not listener.is_old(rt) and not listener.try_update_params(rt)
    assert listener.set("rate", 5.0).successful
    assert rt.rate == 20.0 and listener.is_old(rt)
    assert listener.try_update_params(rt) and rt.rate == 5.0 and not listener.is_old(rt)


def test_parameter_file_layout_wildcard_and_namespaces(tmp_path):
    path = tmp_path / "controllers.yaml"
    path.write_text("""
/**:
  ros__parameters:
    use_sim_time: true
controller_manager:
  ros__parameters:
    update_rate: 500
    arm_controller:
      type: forward_command_controller/ForwardCommandController
/robot1/arm_controller:
  ros__parameters:
    joints: [j1]
    gains: {j1: {p: 2.0}}
""")
    files = load_parameter_file(path)
    assert files["controller_manager"] == {"update_rate": 500,
                                           "arm_controller.type": "forward_command_controller/ForwardCommandController"}
    assert params_for(files, "arm_controller") == {"use_sim_time": True, "joints": ["j1"], "gains.j1.p": 2.0}
    with pytest.raises(ValueError, match="outside any 'ros__parameters' block"):
        load_parameter_file("controller_manager:\n  update_rate: 100\n")
