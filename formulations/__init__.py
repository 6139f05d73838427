"""The formulations layer of droneplan (see DESIGN.md §1); its public names live in its submodules."""

__all__: list[str] = []
