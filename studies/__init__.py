"""The studies layer of droneplan; its public names live in its submodules.

The layers and the direction of their imports: docs/architecture.md.
"""

__all__: list[str] = []
