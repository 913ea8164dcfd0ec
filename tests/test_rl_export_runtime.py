"""robocourse.rl export and runtimes: the normalizer folded in, every runtime equal to numpy, bad files refused."""

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from robocourse.rl import (
    MLPPolicy,
    Normalizer,
    NumpyRuntime,
    OnnxRuntime,
    TorchRuntime,
    export_onnx,
    fold_normalizer,
    load_runtime,
    to_onnx,
    torch_available,
)


@pytest.fixture
def policy():
    rng = np.random.default_rng(7)
    p = MLPPolicy.random((48, 256, 256, 12), seed=3)
    p.normalizer = Normalizer(rng.normal(0, 2, 48), rng.uniform(0.01, 3, 48))
    return p


def test_fold_normalizer_gives_the_same_first_layer_output():
    rng = np.random.default_rng(0)
    w, b = rng.normal(size=(5, 4)), rng.normal(size=5)
    mean, std = rng.normal(size=4), rng.uniform(0.1, 2, 4)
    w2, b2 = fold_normalizer(w, b, mean, std, 1e-2)
    x = rng.normal(size=(10, 4))
    np.testing.assert_allclose(x @ w2.T + b2, ((x - mean) / (std + 1e-2)) @ w.T + b, atol=1e-12)


@pytest.mark.parametrize("mode", ["fold", "graph"])
def test_export_matches_numpy_within_float32_error(policy, tmp_path, mode):
    check = export_onnx(policy, tmp_path / "p.onnx", normalizer=mode)
    assert check.samples == 256
    assert check.max_abs_diff < 1e-4
    model = onnx.load(str(tmp_path / "p.onnx"))
    assert [i.name for i in model.graph.input] == ["obs"]
    assert [o.name for o in model.graph.output] == ["actions"]
    assert model.ir_version == 10
    assert model.opset_import[0].version == 17
    assert all(t.data_type == TensorProto.FLOAT for t in model.graph.initializer)
    assert ("Sub" in [n.op_type for n in model.graph.node]) == (mode == "graph")


def test_normalizer_statistics_saved_beside_the_model(policy, tmp_path):
    check = export_onnx(policy, tmp_path / "p.onnx")
    assert check.normalizer_path == tmp_path / "p_normalizer.npz"
    loaded = Normalizer.load(check.normalizer_path)
    np.testing.assert_array_equal(loaded.mean, policy.normalizer.mean)
    np.testing.assert_array_equal(loaded.std, policy.normalizer.std)


def test_export_without_normalizer_differs_from_the_trained_policy(policy, tmp_path):
    export_onnx(policy, tmp_path / "raw.onnx", normalizer=None)
    rt = OnnxRuntime(tmp_path / "raw.onnx")
    obs = policy.normalizer.mean + 3 * policy.normalizer.std
    assert np.max(np.abs(rt(obs) - policy(obs))) > 0.1


@pytest.mark.parametrize("io_binding", [True, False])
def test_onnx_runtime_equals_numpy_on_many_observations(policy, tmp_path, io_binding):
    export_onnx(policy, tmp_path / "p.onnx")
    rt, ref = OnnxRuntime(tmp_path / "p.onnx", io_binding=io_binding), NumpyRuntime(policy)
    rng = np.random.default_rng(1)
    for _ in range(50):  # a bound buffer must see each new observation
        obs = rng.normal(0, 3, 48)
        np.testing.assert_allclose(rt(obs), policy(obs), atol=1e-4)
        np.testing.assert_allclose(ref(obs), policy(obs), atol=1e-4)
    assert rt.calls == 50 and rt.name.startswith("onnxruntime")


def test_load_runtime_by_extension(policy, tmp_path):
    export_onnx(policy, tmp_path / "p.onnx")
    policy.save(tmp_path / "p.npz")
    assert isinstance(load_runtime(tmp_path / "p.onnx"), OnnxRuntime)
    rt = load_runtime(tmp_path / "p.npz")
    obs = np.ones(48)
    np.testing.assert_allclose(rt(obs), policy(obs), atol=1e-4)
    with pytest.raises(ValueError, match="use .onnx or .npz"):
        load_runtime(tmp_path / "p.pt")


def test_policy_save_load_roundtrip(policy, tmp_path):
    policy.meta = {"env": "arm_reach"}
    back = MLPPolicy.load(policy.save(tmp_path / "p.npz"))
    obs = np.arange(48.0)
    np.testing.assert_array_equal(back(obs), policy(obs))
    assert back.meta == {"env": "arm_reach"}


def _write(tmp_path, name, shape):
    w = numpy_helper.from_array(np.ones((12, shape[1]), np.float32), "W")
    node = helper.make_node("Gemm", [name, "W"], ["actions"], transB=1)
    g = helper.make_graph([node], "g", [helper.make_tensor_value_info(name, TensorProto.FLOAT, shape)],
                          [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [shape[0], 12])], [w])
    m = helper.make_model(g, opset_imports=[helper.make_opsetid("", 17)])
    m.ir_version = 10
    path = tmp_path / f"{name}.onnx"
    onnx.save(m, str(path))
    return path


def test_onnx_with_wrong_input_name_is_refused_with_the_fix(tmp_path):
    with pytest.raises(ValueError, match=r"inputs \['input'\], expected exactly \['obs'\].*input_names"):
        OnnxRuntime(_write(tmp_path, "input", [1, 48]))


def test_onnx_with_dynamic_batch_shape_is_refused(tmp_path):
    with pytest.raises(ValueError, match=r"shape \['batch', 48\]; expected \[1, n\]"):
        OnnxRuntime(_write(tmp_path, "obs", ["batch", 48]))


def test_observation_of_wrong_size_is_refused(policy):
    rt = NumpyRuntime(policy)
    with pytest.raises(ValueError, match="observation has 47 values; this policy takes 48"):
        rt(np.zeros(47))
    assert rt.calls == 0


def test_nan_in_observation_is_refused_naming_the_index(policy, tmp_path):
    export_onnx(policy, tmp_path / "p.onnx")
    for rt in (NumpyRuntime(policy), OnnxRuntime(tmp_path / "p.onnx")):
        obs = np.zeros(48)
        obs[5] = np.nan
        obs[9] = np.inf
        with pytest.raises(ValueError, match=r"non-finite values at indices \[5, 9\]"):
            rt(obs)
        assert rt.calls == 0


def test_torch_runtime_equals_numpy_when_installed(policy):
    if not torch_available():
        with pytest.raises(ImportError, match="torch is not installed"):
            TorchRuntime(policy)
        return
    rt = TorchRuntime(policy)
    obs = np.linspace(-2, 2, 48)
    np.testing.assert_allclose(rt(obs), policy(obs), atol=1e-4)


def test_to_onnx_refuses_an_unknown_normalizer_mode(policy):
    with pytest.raises(ValueError, match="'fold', 'graph' or None"):
        to_onnx(policy, normalizer="inline")
