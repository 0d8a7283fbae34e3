"""How many stage-1 training samples come from crews that need no movement decision.

In stage-1 training every crew of every env copy gives PPO one sample per vector-env step
(SuperSuit's parameter sharing). A crew that tasks, fetches, waits or has left gets an
all-zero observation and its action is ignored, yet its sample still costs a forward pass, a
slot in the rollout buffer and a share of the update, with reward 0. This script drives the
training env (``training.stage1.MixedStageEnv``, stage-1 episodes and the full-CMDP episodes
mixed in after ``stage2_after_steps``) with a reaching model and counts, per episode kind, the
samples and those of crews that need a decision.

    python benchmarks/bench_samples.py [--model models/stage1_reaching.zip] [--episodes 1]
"""

from __future__ import annotations

import argparse

import cmdp_pymunk


def count(env, navigator, seeds) -> tuple[int, int, int]:
    """(vector-env steps, samples, samples of crews that need a decision) over the seeds."""
    steps = samples = deciding = 0
    for seed in seeds:
        observations, _ = env.reset(seed=seed)
        navigator.reset(seed)
        while env.agents:
            steps += 1
            samples += len(env.agents)
            engine = env.engine
            crews = engine.site.crews
            deciding += sum(engine.needs_action(crews[env.agent_index[a]]) for a in env.agents)
            observations, *_ = env.step(env.agent_actions(navigator, observations))
    return steps, samples, deciding


def main(argv=None) -> int:
    from agents.models import PolicyNavigator
    from training.stage1 import DEFAULT_CONFIG, MixedStageEnv, Stage1Config

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("--model", default="models/stage1_reaching.zip")
    parser.add_argument("--episodes", type=int, default=1, help="per episode kind")
    args = parser.parse_args(argv)
    config = Stage1Config.load(DEFAULT_CONFIG, [])
    case = cmdp_pymunk.load_case(config.case)
    navigator = PolicyNavigator(args.model)
    shares = {}
    for stage in (1, 2):
        # stage 2 every reset (share 1, past the start), or never (share 0)
        kind = config.model_copy(update={"stage2_share": float(stage == 2)})
        env = MixedStageEnv(kind, case, start_steps=config.stage2_after_steps)
        navigator.bind(env.engine)
        steps, samples, deciding = count(env, navigator, range(100, 100 + args.episodes))
        shares[stage] = (steps, 1.0 - deciding / samples)
        print(f"stage-{stage} episodes (cut at {env.max_time_s:,.0f} s): {steps} vector-env "
              f"steps, {samples} samples, {deciding} from crews that need a decision: "
              f"{1 - deciding / samples:.1%} need none")
    # after stage2_after_steps, a share of the resets are stage-2 episodes, longer ones
    per_reset = {s: shares[s][0] / args.episodes for s in shares}
    weight2 = config.stage2_share * per_reset[2]
    weight1 = (1 - config.stage2_share) * per_reset[1]
    mixed = (weight1 * shares[1][1] + weight2 * shares[2][1]) / (weight1 + weight2)
    print(f"after {config.stage2_after_steps:,} agent-steps ({config.stage2_share:.0%} of resets "
          f"full-CMDP): {mixed:.1%} of the samples need no decision")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
