"""cmdp-export: the ONNX file, run by onnxruntime, gives SB3's own outputs."""

from pathlib import Path

import numpy as np
import onnxruntime as ort  # the onnx extra, which make test installs
import pytest
import torch
from gymnasium import spaces

from tests.test_lean_actor import COMMITTED, observations, random_ppo
from training import onnx_export
from training.commands import export


def run(path, obs):
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    names = [o.name for o in session.get_outputs()]
    return dict(zip(names, session.run(None, {"obs": obs}), strict=True))


def test_committed_reaching_model_exports_and_matches_sb3(tmp_path):
    from stable_baselines3 import PPO

    out = tmp_path / "reach.onnx"
    assert export.main([str(COMMITTED), str(out)]) == 0
    model = PPO.load(str(COMMITTED), device="cpu")
    obs = observations(119, n=300) * 0.5
    got = run(out, obs)
    assert set(got) == {"logits", "action"} and got["action"].dtype == np.int64
    with torch.no_grad():
        dist = model.policy.get_distribution(torch.as_tensor(obs))
    # the raw logits differ from torch's normalised ones by a constant per sub-action
    start = 0
    for k, n in enumerate((4, 3, 3)):
        ours = got["logits"][:, start:start + n]
        ours = ours - np.log(np.exp(ours).sum(axis=1, keepdims=True))
        np.testing.assert_allclose(ours, dist.distribution[k].logits.numpy(), atol=1e-4)
        start += n
    expected, _ = model.predict(obs, deterministic=True)
    np.testing.assert_array_equal(got["action"], expected)


def test_box_policy_exports_mean_log_std_and_clipped_action(tmp_path):
    model = random_ppo(7, spaces.Box(-1.0, 1.0, (2,), np.float32))
    path = tmp_path / "eval.zip"
    model.save(str(path))
    out = tmp_path / "eval.onnx"
    assert export.main([str(path), str(out)]) == 0
    obs = observations(7, n=200)
    got = run(out, obs)
    with torch.no_grad():
        dist = model.policy.get_distribution(torch.as_tensor(obs)).distribution
    np.testing.assert_allclose(got["mean"], dist.mean.numpy(), atol=1e-5)
    np.testing.assert_allclose(got["log_std"], model.policy.log_std.detach().numpy(),
                               rtol=1e-6)
    expected, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(got["action"], expected, atol=1e-5)


def test_missing_model_is_reported(tmp_path, capsys):
    assert export.main([str(tmp_path / "nope.zip"), str(tmp_path / "x.onnx")]) == 2
    assert "no such model file" in capsys.readouterr().err
    assert not Path(tmp_path / "x.onnx").exists()


@pytest.mark.parametrize("typed", [False, True])
def test_masked_choice_model_exports_and_matches_torch_on_recorded_states(tmp_path, typed):
    """A stage-2 masked-choice model (MaskablePPO, CandidateScorerPolicy; typed: with its
    per-type term) with every weight made non-zero: on candidate rows and masks recorded
    from an episode the ONNX logits equal the policy's own (masked ones -1e8) and its action
    is model.predict's."""
    from sb3_contrib import MaskablePPO

    from training import stage2
    from training.stage2 import Stage2Config

    # the event floor records the same kind of rows as the pymunk floor, in a fraction of the time
    config = Stage2Config(action="candidate", central_critic=False, n_envs=1, num_cpus=1,
                          typed=typed, fidelity="event")
    case = stage2.training_case(config)
    floor = stage2.make_decision_loop(config, case)
    model = stage2.new_candidate_model(config, stage2.make_vec_env(config, case, 0))
    generator = torch.Generator().manual_seed(0)
    with torch.no_grad():  # untrained, the linear and residual heads are zero: perturb them
        for p in model.policy.action_net.parameters():
            p.add_(0.3 * torch.randn(p.shape, generator=generator))
    path = tmp_path / "candidate.zip"
    model.save(path)
    states = []

    def record(obs):
        states.append((obs, floor.action_masks()))
        return 0

    stage2.play_floor(floor, 7, record)
    obs = np.stack([s[0] for s in states]).astype(np.float32)
    masks = np.stack([s[1] for s in states]).astype(bool)
    assert len(states) > 20 and not masks.all()  # some decisions have fewer candidates

    out = onnx_export.export(path, tmp_path / "candidate.onnx")
    session = ort.InferenceSession(str(out), providers=["CPUExecutionProvider"])
    logits, action = session.run(["logits", "action"], {"obs": obs, "mask": masks})
    loaded = MaskablePPO.load(path, device="cpu")
    with torch.no_grad():
        raw = loaded.policy.action_net(torch.as_tensor(obs)).numpy()
    assert np.allclose(logits[masks], raw[masks], atol=1e-4)
    assert (logits[~masks] == onnx_export.HUGE_NEG).all()
    expected, _ = loaded.predict(obs, action_masks=masks, deterministic=True)
    assert (action == expected).all() and len(set(expected.tolist())) > 1
