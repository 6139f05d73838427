"""Run every notebook under ``notebooks/`` in fast mode and save it with its outputs.

The repository copies carry the outputs of this reduced run (``DRONEPLAN_FAST=1``: smaller
instances, shorter limits), so that a reader sees every table and figure on the code host and
on the documentation site without running anything. Each saved notebook records, in its
metadata, the SHA-256 of its code cells' sources; ``tests/test_notebooks.py`` fails when a
cell was edited after the outputs were saved. Run it after editing a notebook::

    python docs/execute_notebooks.py            # all notebooks
    python docs/execute_notebooks.py 02_cells   # one
"""

from __future__ import annotations

import hashlib
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
METADATA_KEY = "droneplan"


def sources_digest(nb) -> str:
    """SHA-256 of the code cells' sources, in order: what the saved outputs were computed from."""
    digest = hashlib.sha256()
    for cell in nb.cells:
        if cell.cell_type == "code":
            digest.update(cell.source.encode("utf-8") + b"\0")
    return digest.hexdigest()


def execute(path: Path, *, timeout: float = 900.0) -> None:
    """Run the notebook at ``path`` in fast mode (``DRONEPLAN_FAST=1``, Agg backend) in a scratch
    folder and write it back with its outputs and the digest of its sources."""
    import nbformat
    from nbclient import NotebookClient

    os.environ["DRONEPLAN_FAST"] = "1"
    os.environ["MPLBACKEND"] = "Agg"
    nb = nbformat.read(path, as_version=4)
    with tempfile.TemporaryDirectory() as scratch:
        NotebookClient(
            nb, timeout=timeout, kernel_name="python3", resources={"metadata": {"path": scratch}}
        ).execute()
    for cell in nb.cells:
        if cell.cell_type == "code":
            cell.outputs = [out for out in cell.outputs if not _progress_noise(out)]
    nb.metadata[METADATA_KEY] = {"sources_sha256": sources_digest(nb), "mode": "DRONEPLAN_FAST=1"}
    nbformat.write(nb, path)


def _progress_noise(output) -> bool:
    """A progress bar's redraw or tqdm's note that the notebook has no widgets (stderr)."""
    if output.get("output_type") != "stream" or output.get("name") != "stderr":
        return False
    text = output.get("text", "")
    return "\r" in text or "TqdmWarning" in text or "IProgress" in text


def main(names: list[str]) -> int:
    paths = sorted(NOTEBOOKS.glob("*.ipynb"))
    if names:
        paths = [p for p in paths if p.stem in names or p.name in names]
        if not paths:
            raise SystemExit(f"no notebook named {names} under {NOTEBOOKS}")
    for path in paths:
        print(f"running {path.name} ...", flush=True)
        execute(path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
