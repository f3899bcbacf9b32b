"""Reinforcement-learning tasks on the skidsteer robot, as dm_control's suite.

```python
from skidsteer import tasks
env = tasks.load("pioneer3at", "swivel", task_kwargs={"omega_deg_s": 30, "random": 0})
```

Each domain module defines `SUITE = containers.TaggedTasks()` of factory
functions returning a `dm_control.rl.control.Environment`; ALL_TASKS,
TASKS_BY_DOMAIN and TAGS are built from them the way dm_control.suite does.
"""

from __future__ import annotations

import collections
import inspect

from skidsteer.tasks._headless import default_to_egl

default_to_egl()  # before dm_control picks its OpenGL backend (headless machines)

from skidsteer.tasks import pioneer3at  # noqa: E402

_DOMAINS = {name: module for name, module in dict(pioneer3at=pioneer3at).items()
            if inspect.ismodule(module) and hasattr(module, "SUITE")}


def _get_tasks(tag):
    """(domain name, task name) pairs, of every task or of those with tag."""
    result = []
    for domain_name in sorted(_DOMAINS):
        domain = _DOMAINS[domain_name]
        tasks_in_domain = domain.SUITE if tag is None else domain.SUITE.tagged(tag)
        for task_name in tasks_in_domain.keys():
            result.append((domain_name, task_name))
    return tuple(result)


def _get_tasks_by_domain(tasks):
    result = collections.defaultdict(list)
    for domain_name, task_name in tasks:
        result[domain_name].append(task_name)
    return {k: tuple(v) for k, v in result.items()}


ALL_TASKS = _get_tasks(tag=None)
TASKS_BY_DOMAIN = _get_tasks_by_domain(ALL_TASKS)
# tag -> the (domain, task) pairs carrying it
TAGS = {tag: _get_tasks(tag)
        for tag in sorted({t for domain in _DOMAINS.values() for t in domain.SUITE.tags()})}


def load(domain_name, task_name, task_kwargs=None, environment_kwargs=None,
         visualize_reward=False):
    """An environment from a domain name, a task name and optional settings.

    Args:
      domain_name: e.g. "pioneer3at".
      task_name: e.g. "swivel" (see TASKS_BY_DOMAIN).
      task_kwargs: keyword arguments of the task's factory function (floor,
        omega_deg_s, build, lambda_max, time_limit, control_timestep, random, ...).
      environment_kwargs: keyword arguments of `control.Environment`.
      visualize_reward: tint the chassis by the reward in rendered frames.

    Raises:
      ValueError: unknown domain or task, or a bad task option (named).
    """
    if domain_name not in _DOMAINS:
        raise ValueError(f"Domain {domain_name!r} does not exist: use one of {sorted(_DOMAINS)}")
    domain = _DOMAINS[domain_name]
    if task_name not in domain.SUITE:
        raise ValueError(f"Level {task_name!r} does not exist in domain {domain_name!r}: "
                         f"use one of {list(domain.SUITE)}")
    task_kwargs = dict(task_kwargs or {})
    if environment_kwargs is not None:
        task_kwargs["environment_kwargs"] = environment_kwargs
    env = domain.SUITE[task_name](**task_kwargs)
    env.task.visualize_reward = visualize_reward
    return env


__all__ = ["ALL_TASKS", "TASKS_BY_DOMAIN", "TAGS", "load"]
