"""The paper's reported figures, copied into the package (data/paper_results.json) with their
source: Tariverdi et al. 2021, Front. Robot. AI 8:631303."""

import json
from functools import lru_cache
from importlib.resources import files


@lru_cache(maxsize=1)
def paper_results() -> dict:
    """The whole table of reported results (errors in mm or degrees, bandwidths in Hz)."""
    return json.loads(files("softrnn").joinpath("data/paper_results.json").read_text())


def paper_case(key: str) -> dict:
    """One case's reported figures ('ellipse', 'square_tip', 'semicircle', 'magnetic_experiment')."""
    return paper_results()["cases"][key]
