"""Gymnasium environments of the closed-loop problems (thesis ch. 3, 5, 6), one module per problem.

Each environment steps the same dynamics as the problem's simulator and maps its observation
and command dataclasses to and from flat numpy vectors; the same conversion functions back the
problem's ``policy_controller``, which flies an ``obs_vector -> action`` policy in ``simulate``:

- :mod:`droneplan.scenarios.envs.herding`: ``HerdingEnv`` (herding with barking drones);
- :mod:`droneplan.scenarios.envs.shark`: ``InterceptionEnv`` (shark interception);
- :mod:`droneplan.scenarios.envs.covert`: ``CovertEnv`` (covert observation).

The modules import gymnasium; this package imports none of them.
"""

__all__: list[str] = []
