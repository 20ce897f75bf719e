#!/usr/bin/env python3
"""PPO on BW4T, in one file: JAX and optax over ``bw4t.env.vector_env``.

Every learning robot of every match is one row of the vector environment, and all rows
share one actor-critic (parameter sharing): each row is one robot's trajectory, and with
the team reward every robot of a match is rewarded for every block its team delivers.
The actor's logits are masked with the environment's action mask (an action that is not
valid now gets a large negative logit), both when sampling and in the loss.

    pip install "bw4t[train]"            # jax and optax
    python examples/train_ppo.py         # the default run (under 2 minutes on 2 cores)
    python examples/train_ppo.py --smoke # a few seconds: checks everything runs

Each update prints one JSON line (a learning curve: ``mean_episode_return`` and
``mean_delivered``, the blocks a team delivers per episode, over the episodes that ended
during the update's rollout); the last line is a summary (``"summary": true``).

A truncated episode (the tick limit) is treated as ended, without bootstrapping: the
observation holds the time over the tick limit, so the end is part of what is observed.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

import bw4t.env
import bw4t.eval

#: The logit given to an action the mask forbids.
MASKED_LOGIT = -1e9


@dataclass
class Args:
    """Every setting of a run; each is a flag (``--total-steps``, ``--num-matches``, ...)."""

    # The environment.
    map: str = "fixed"
    """A shipped map's name or a map file (``fixed``: nine rooms, fixed blocks and sequence)."""
    robots: int = 3
    """Learning robots per match (they share one policy)."""
    num_matches: int = 32
    """Matches stepped together; the vector has ``num_matches * robots`` rows."""
    ticks_per_step: int = 50
    """Simulated ticks per step (20 ticks a simulated second)."""
    max_ticks: int = 3000
    """An episode's tick limit (it is truncated there)."""
    wrong_drop: float = 0.0
    """The reward for a block of the wrong colour dropped in the drop zone (the
    environment's default is -0.5)."""
    threads: Optional[int] = None
    """Threads stepping the matches (default: the machine's cores)."""
    seed: int = 0

    # The run.
    total_steps: int = 3_000_000
    """Agent steps (rows x steps) over the whole run."""
    num_steps: int = 64
    """Steps of each row per rollout (one update per rollout)."""

    # PPO.
    learning_rate: float = 5e-4
    anneal_lr: bool = True
    gamma: float = 0.99
    gae_lambda: float = 0.95
    num_minibatches: int = 4
    update_epochs: int = 4
    clip_coef: float = 0.2
    ent_coef: float = 0.01
    shaping: float = 0.1
    """Scale of the potential-based shaping (0: the environment's rewards alone)."""
    messages: bool = False
    """Let the robots send messages (the ``say_*`` actions); off, the learner masks them
    out itself."""
    hall_drops: bool = False
    """Let a robot put a block down outside a room, where the block leaves the world;
    off, the learner masks ``put_down`` out there itself."""
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    hidden: int = 128
    """Units of each of the two hidden layers of the actor and of the critic."""

    smoke: bool = False
    """A very short run with tiny sizes, which checks its own figures are finite."""

    # After training.
    eval_tier: str = ""
    """Play the trained policy (greedy: the most likely allowed action) on this tier of the
    suite (``bw4t eval tiers``; ``learn`` has this map's layout) and print its leaderboard
    row as the last line (``{"eval": ROW}``)."""
    eval_split: str = "dev"
    """The tier's split: ``dev``, ``test`` (held out), or both (``dev,test``: a row each)."""
    eval_out: str = ""
    """Where the evaluation writes its matches and row (default: under runs/)."""


def parse_args(argv: Optional[List[str]] = None) -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for field in dataclasses.fields(Args):
        flag = "--" + field.name.replace("_", "-")
        default = field.default
        if field.type in ("bool", bool):
            parser.add_argument(flag, action=argparse.BooleanOptionalAction, default=default)
        elif field.name == "threads":
            parser.add_argument(flag, type=int, default=default)
        else:
            parser.add_argument(flag, type=type(default), default=default)
    args = Args(**vars(parser.parse_args(argv)))
    if args.smoke:
        # Tiny everything, short episodes so that some end, and two updates.
        args.num_matches = min(args.num_matches, 2)
        args.num_steps = 16
        args.max_ticks = min(args.max_ticks, 400)
        args.hidden = 32
        args.num_minibatches = 2
        args.update_epochs = 2
        args.total_steps = 2 * args.num_matches * args.robots * args.num_steps
    return args


# ---------------------------------------------------------------------- shaping


class Potential:
    """A robot's progress towards the next delivery, read from its own observation, as a
    potential ``phi``: 1 in a room (not the drop zone) where the next colour of the
    sequence is visible, 1 holding a block of that colour, 3 holding it in the drop zone,
    0 otherwise.

    The learner is trained on ``r + scale * (gamma * phi(s') - phi(s))``, ``s'`` the
    state the step led to (for a step that ended an episode, its last state). Along an
    episode the extra terms add up to ``scale * (gamma^T phi(s_T) - phi(s_0))``: going
    back and forth earns nothing. The terms tell the learner about the steps of a
    delivery long before a first delivery happens by chance (on these maps almost
    never): entering the right room, leaving it with the block rather than without, and
    bringing it into the drop zone. Picking the block up and putting it down in a room
    change nothing: were dropping it outside the drop zone punished, the learner would
    soon never put a block down at all, the drop zone included, and hold it for ever."""

    def __init__(self, spec) -> None:
        layout = {name: (offset, length) for name, offset, length in spec.obs_layout}
        self.colours = len(spec.colours)
        self.seg = {name: slice(offset, offset + length) for name, (offset, length) in layout.items()}
        self.length = layout["delivered"][1]
        self.drop_zone = layout["at"][0] + list(spec.places).index("DropZone")

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        rows = obs.shape[0]
        sequence = obs[:, self.seg["sequence"]].reshape(rows, self.length, self.colours)
        index = obs[:, self.seg["sequence_index"]]
        # The colour wanted next (zeros once the sequence is complete).
        wanted = np.einsum("rl,rlc->rc", index[:, : self.length], sequence)
        holds_wanted = (obs[:, self.seg["held_colour"]] * wanted).sum(axis=1) > 0
        in_drop_zone = obs[:, self.drop_zone] > 0
        in_room = obs[:, self.seg["in_room"]][:, 0] > 0
        sees_wanted = (obs[:, self.seg["room_colours"]] * wanted).sum(axis=1) > 0
        searching = in_room & ~in_drop_zone & sees_wanted
        phi = np.where(holds_wanted, 1.0 + 2.0 * in_drop_zone, searching)
        return phi.astype(np.float32)


class LearnerMask:
    """The actions the learner may choose now: the environment's mask, less the actions
    it has chosen to do without. Without messages, 29 actions that do nothing for a
    learner that cannot read them are gone (the entropy bonus would spread the policy
    over them). Without drops outside rooms, ``put_down`` can only lose the block in a
    hall; allowed there, the learner soon learns never to put anything down, and then
    cannot find out that doing it in the drop zone delivers."""

    def __init__(self, spec, args: Args) -> None:
        self.usable = np.ones(spec.n_actions, np.bool_)
        for name, offset, length in spec.action_layout:
            if name.startswith("say_") and not args.messages:
                self.usable[offset : offset + length] = False
            if name == "put_down":
                self.put_down = offset
        self.in_room = None if args.hall_drops else dict((n, o) for n, o, _ in spec.obs_layout)["in_room"]

    def __call__(self, obs: np.ndarray, env_mask: np.ndarray) -> np.ndarray:
        mask = (env_mask > 0) & self.usable
        if self.in_room is not None:
            mask[:, self.put_down] &= obs[:, self.in_room] > 0
        return mask


# ---------------------------------------------------------------------- the network


def init_mlp(key: jax.Array, sizes: List[int], last_scale: float) -> List[Dict[str, jax.Array]]:
    """Dense layers of ``sizes``, orthogonally initialised (gain sqrt 2; the last one's
    ``last_scale``), biases zero."""
    layers = []
    keys = jax.random.split(key, len(sizes) - 1)
    for i, (k, n_in, n_out) in enumerate(zip(keys, sizes[:-1], sizes[1:])):
        scale = last_scale if i == len(sizes) - 2 else math.sqrt(2.0)
        w = jax.nn.initializers.orthogonal(scale)(k, (n_in, n_out), jnp.float32)
        layers.append({"w": w, "b": jnp.zeros(n_out, jnp.float32)})
    return layers


def mlp(layers: List[Dict[str, jax.Array]], x: jax.Array) -> jax.Array:
    for layer in layers[:-1]:
        x = jnp.tanh(x @ layer["w"] + layer["b"])
    return x @ layers[-1]["w"] + layers[-1]["b"]


def init_params(key: jax.Array, obs_len: int, n_actions: int, hidden: int) -> Dict:
    k_actor, k_critic = jax.random.split(key)
    return {
        "actor": init_mlp(k_actor, [obs_len, hidden, hidden, n_actions], 0.01),
        "critic": init_mlp(k_critic, [obs_len, hidden, hidden, 1], 1.0),
    }


def masked_logits(params: Dict, obs: jax.Array, mask: jax.Array) -> jax.Array:
    """The actor's logits, with every action the mask forbids at ``MASKED_LOGIT``."""
    return jnp.where(mask, mlp(params["actor"], obs), MASKED_LOGIT)


def log_policy(params: Dict, obs: jax.Array, mask: jax.Array) -> jax.Array:
    """The policy's log-probabilities (a forbidden action's is about ``MASKED_LOGIT``)."""
    return jax.nn.log_softmax(masked_logits(params, obs, mask))


def value(params: Dict, obs: jax.Array) -> jax.Array:
    return mlp(params["critic"], obs)[..., 0]


@jax.jit
def act(params: Dict, obs: jax.Array, mask: jax.Array, key: jax.Array) -> Tuple[jax.Array, ...]:
    """An action per row sampled from the masked policy, its log-probability and the
    value; and the next random key."""
    key, sample_key = jax.random.split(key)
    logp_all = log_policy(params, obs, mask)
    action = jax.random.categorical(sample_key, logp_all)
    logprob = jnp.take_along_axis(logp_all, action[:, None], axis=1)[:, 0]
    return action, logprob, value(params, obs), key


def greedy_policy(params: Dict, spec, args: Args):
    """The trained actor as a ``bw4t.eval`` policy: for every robot, the allowed action
    (by the learner's own mask) with the highest logit."""
    learner_mask = LearnerMask(spec, args)

    def policy(observations: Dict[str, Dict[str, np.ndarray]]) -> Dict[str, int]:
        names = list(observations)
        obs = np.stack([observations[name]["observation"] for name in names])
        if obs.shape[1] != spec.obs_len:
            raise ValueError(
                f"the tier's map gives {obs.shape[1]} observation values, the policy was trained on {spec.obs_len}: "
                "evaluate it on a tier of its map's layout (learn, for the default layout)"
            )
        mask = learner_mask(obs, np.stack([observations[name]["action_mask"] for name in names]))
        chosen = np.asarray(jnp.argmax(masked_logits(params, jnp.asarray(obs), jnp.asarray(mask)), axis=1))
        return {name: int(action) for name, action in zip(names, chosen)}

    return policy


# ---------------------------------------------------------------------- PPO


@jax.jit
def gae(
    rewards: jax.Array, values: jax.Array, dones: jax.Array, last_value: jax.Array, gamma: float, lam: float
) -> Tuple[jax.Array, jax.Array]:
    """Advantages and returns (both ``(steps, rows)``). ``dones[t]``: the episode ended
    with step ``t`` (its reward is ``rewards[t]``), so nothing after it is bootstrapped."""
    next_values = jnp.concatenate([values[1:], last_value[None]], axis=0)

    def back(carry: jax.Array, x: Tuple[jax.Array, ...]) -> Tuple[jax.Array, jax.Array]:
        reward, v, next_v, done = x
        alive = 1.0 - done
        delta = reward + gamma * next_v * alive - v
        adv = delta + gamma * lam * alive * carry
        return adv, adv

    _, advantages = jax.lax.scan(back, jnp.zeros_like(last_value), (rewards, values, next_values, dones), reverse=True)
    return advantages, advantages + values


def ppo_loss(params: Dict, batch: Dict[str, jax.Array], args: Args) -> Tuple[jax.Array, Dict[str, jax.Array]]:
    logp_all = log_policy(params, batch["obs"], batch["mask"])
    logp = jnp.take_along_axis(logp_all, batch["actions"][:, None], axis=1)[:, 0]
    log_ratio = logp - batch["logprobs"]
    ratio = jnp.exp(log_ratio)

    adv = batch["advantages"]
    adv = (adv - adv.mean()) / (adv.std() + 1e-8)
    pg_loss = jnp.maximum(-adv * ratio, -adv * jnp.clip(ratio, 1 - args.clip_coef, 1 + args.clip_coef)).mean()

    v = value(params, batch["obs"])
    v_clipped = batch["values"] + jnp.clip(v - batch["values"], -args.clip_coef, args.clip_coef)
    v_loss = 0.5 * jnp.maximum((v - batch["returns"]) ** 2, (v_clipped - batch["returns"]) ** 2).mean()

    # Entropy over the allowed actions only (a forbidden one has probability 0).
    probs = jnp.exp(logp_all)
    entropy = -jnp.where(batch["mask"], probs * logp_all, 0.0).sum(axis=1).mean()

    loss = pg_loss - args.ent_coef * entropy + args.vf_coef * v_loss
    approx_kl = ((ratio - 1) - log_ratio).mean()
    clipfrac = (jnp.abs(ratio - 1) > args.clip_coef).mean()
    return loss, {
        "pg_loss": pg_loss,
        "v_loss": v_loss,
        "entropy": entropy,
        "approx_kl": approx_kl,
        "clipfrac": clipfrac,
    }


def make_update(args: Args, optimizer: optax.GradientTransformation):
    """The jitted update: ``update_epochs`` passes over the rollout in shuffled minibatches."""
    grad_fn = jax.value_and_grad(ppo_loss, has_aux=True)

    def minibatch_step(carry, minibatch):
        params, opt_state = carry
        (_, stats), grads = grad_fn(params, minibatch, args)
        updates, opt_state = optimizer.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), stats

    @jax.jit
    def update(params, opt_state, batch, key):
        size = batch["actions"].shape[0]
        mb = size // args.num_minibatches

        def epoch(carry, epoch_key):
            order = jax.random.permutation(epoch_key, size)[: mb * args.num_minibatches]
            shuffled = jax.tree_util.tree_map(
                lambda x: x[order].reshape((args.num_minibatches, mb) + x.shape[1:]), batch
            )
            return jax.lax.scan(minibatch_step, carry, shuffled)

        keys = jax.random.split(key, args.update_epochs)
        (params, opt_state), stats = jax.lax.scan(epoch, (params, opt_state), keys)
        return params, opt_state, jax.tree_util.tree_map(jnp.mean, stats)

    return update


# ---------------------------------------------------------------------- the run


def main(argv: Optional[List[str]] = None) -> int:
    args = parse_args(argv)
    env = bw4t.env.vector_env(
        num_matches=args.num_matches,
        map=args.map,
        robots=args.robots,
        ticks_per_step=args.ticks_per_step,
        max_ticks=args.max_ticks,
        rewards=bw4t.env.Rewards(wrong_drop=args.wrong_drop),
        threads=args.threads,
        seed=args.seed,
    )
    rows = env.num_envs
    obs_len = env.spec_native.obs_len
    n_actions = env.spec_native.n_actions
    layout = {name: (offset, length) for name, offset, length in env.spec_native.obs_layout}
    delivered_at, sequence_length = layout["delivered"]
    delivered_seg = slice(delivered_at, delivered_at + sequence_length)
    batch_size = rows * args.num_steps
    num_updates = max(1, args.total_steps // batch_size)

    key = jax.random.PRNGKey(args.seed)
    key, init_key = jax.random.split(key)
    params = init_params(init_key, obs_len, n_actions, args.hidden)
    steps_per_update = args.update_epochs * args.num_minibatches
    lr = (
        optax.linear_schedule(args.learning_rate, 0.0, num_updates * steps_per_update)
        if args.anneal_lr
        else args.learning_rate
    )
    optimizer = optax.chain(optax.clip_by_global_norm(args.max_grad_norm), optax.adam(lr, eps=1e-5))
    opt_state = optimizer.init(params)
    update = make_update(args, optimizer)

    # The rollout's buffers, allocated once.
    b_obs = np.zeros((args.num_steps, rows, obs_len), np.float32)
    b_mask = np.zeros((args.num_steps, rows, n_actions), np.bool_)
    b_actions = np.zeros((args.num_steps, rows), np.int32)
    b_logprobs = np.zeros((args.num_steps, rows), np.float32)
    b_values = np.zeros((args.num_steps, rows), np.float32)
    b_rewards = np.zeros((args.num_steps, rows), np.float32)
    b_dones = np.zeros((args.num_steps, rows), np.float32)

    # Each row's episode so far.
    episode_return = np.zeros(rows, np.float64)
    episode_length = np.zeros(rows, np.int64)
    all_returns: List[float] = []
    all_delivered: List[float] = []
    first_match_row = np.arange(rows) % args.robots == 0

    potential = Potential(env.spec_native)
    learner_mask = LearnerMask(env.spec_native, args)

    obs, _ = env.reset(seed=args.seed)
    next_obs = obs["observation"]
    next_mask = learner_mask(next_obs, obs["action_mask"])
    phi = potential(next_obs)
    global_step = 0
    start = time.time()
    lines: List[Dict] = []

    for k in range(1, num_updates + 1):
        returns: List[float] = []
        lengths: List[int] = []
        delivered: List[float] = []
        phi_sum = np.zeros(rows, np.float64)
        for t in range(args.num_steps):
            b_obs[t] = next_obs
            b_mask[t] = next_mask
            action, logprob, v, key = act(params, next_obs, next_mask, key)
            action = np.asarray(action)
            b_actions[t] = action
            b_logprobs[t] = np.asarray(logprob)
            b_values[t] = np.asarray(v)

            obs, reward, terminated, truncated, infos = env.step(action)
            ended = terminated | truncated
            next_obs = obs["observation"]
            next_mask = learner_mask(next_obs, obs["action_mask"])
            global_step += rows

            # The state each step led to: for a row whose episode ended, the episode's
            # last one (its row of `next_obs` already begins the next episode).
            reached = next_obs
            if ended.any():
                reached = next_obs.copy()
                for row in np.flatnonzero(ended):
                    reached[row] = infos["final_obs"][row]["observation"]
            reached_phi = potential(reached)
            b_rewards[t] = reward + args.shaping * (args.gamma * reached_phi - phi)
            b_dones[t] = ended
            phi = potential(next_obs) if ended.any() else reached_phi
            phi_sum += reached_phi

            episode_return += reward
            episode_length += 1
            for row in np.flatnonzero(ended):
                returns.append(float(episode_return[row]))
                lengths.append(int(episode_length[row]))
                if first_match_row[row]:  # every robot of a match sees the same deliveries
                    delivered.append(float(reached[row, delivered_seg].sum()))
            episode_return[ended] = 0.0
            episode_length[ended] = 0

        _, _, last_value, key = act(params, next_obs, next_mask, key)
        advantages, targets = gae(
            jnp.asarray(b_rewards), jnp.asarray(b_values), jnp.asarray(b_dones), last_value, args.gamma, args.gae_lambda
        )
        batch = {
            "obs": jnp.asarray(b_obs.reshape(batch_size, obs_len)),
            "mask": jnp.asarray(b_mask.reshape(batch_size, n_actions)),
            "actions": jnp.asarray(b_actions.reshape(batch_size)),
            "logprobs": jnp.asarray(b_logprobs.reshape(batch_size)),
            "values": jnp.asarray(b_values.reshape(batch_size)),
            "advantages": advantages.reshape(batch_size),
            "returns": targets.reshape(batch_size),
        }
        key, update_key = jax.random.split(key)
        params, opt_state, stats = update(params, opt_state, batch, update_key)

        all_returns += returns
        all_delivered += delivered
        line = {
            "update": k,
            "global_step": global_step,
            "episodes_ended": len(delivered),
            "mean_episode_return": float(np.mean(returns)) if returns else None,
            "mean_episode_length": float(np.mean(lengths)) if lengths else None,
            "mean_delivered": float(np.mean(delivered)) if delivered else None,
            "completed": float(np.mean(np.asarray(delivered) >= sequence_length)) if delivered else None,
            "mean_shaped_reward": float(b_rewards.mean()),
            "mean_potential": float(phi_sum.mean() / args.num_steps),
            **{name: float(x) for name, x in stats.items()},
            "sps": int(global_step / (time.time() - start)),
            "seconds": round(time.time() - start, 1),
        }
        lines.append(line)
        print(json.dumps(line), flush=True)

    env.close()
    tail = max(1, len(lines) // 10)

    def mean_of(name: str, part: List[Dict]) -> Optional[float]:
        xs = [line[name] for line in part if line[name] is not None]
        return float(np.mean(xs)) if xs else None

    summary = {
        "summary": True,
        "updates": num_updates,
        "global_step": global_step,
        "seconds": round(time.time() - start, 1),
        "episodes_ended": len(all_delivered),
        "mean_episode_return": float(np.mean(all_returns)) if all_returns else None,
        "mean_delivered": float(np.mean(all_delivered)) if all_delivered else None,
        # The learning curve in two figures: its first and its last tenth of updates.
        "first_return": mean_of("mean_episode_return", lines[:tail]),
        "last_return": mean_of("mean_episode_return", lines[-tail:]),
        "first_delivered": mean_of("mean_delivered", lines[:tail]),
        "last_delivered": mean_of("mean_delivered", lines[-tail:]),
        "args": dataclasses.asdict(args),
    }
    print(json.dumps(summary), flush=True)

    if args.smoke:
        figures = [x for line in lines for x in line.values() if isinstance(x, float)]
        figures += [float(x) for leaf in jax.tree_util.tree_leaves(params) for x in np.ravel(leaf)]
        if not all(math.isfinite(x) for x in figures):
            print("smoke: a figure is not finite", file=sys.stderr)
            return 1
        if not all_returns:
            print("smoke: no episode ended", file=sys.stderr)
            return 1
    if args.eval_tier:
        settings = f"map={args.map} seed={args.seed} total_steps={args.total_steps} ticks_per_step={args.ticks_per_step}"
        for split in args.eval_split.split(","):
            out = f"{args.eval_out}/{split}" if args.eval_out else None
            row = bw4t.eval.evaluate(
                greedy_policy(params, env.spec_native, args),
                args.eval_tier,
                agent="python:examples/train_ppo.py",
                split=split.strip(),
                ticks_per_step=args.ticks_per_step,
                out=out,
                meta={"name": "ppo-example", "harness": f"train_ppo.py greedy, {settings}"},
            )
            print(json.dumps({"eval": row}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
