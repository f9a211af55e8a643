"""The population: its size and order, seeds, content ids, the split into batch structure and member values."""

from __future__ import annotations

from ftc_mj.campaign.population import population
from ftc_mj.campaign.schema import CampaignSpec


def spec(**changes) -> CampaignSpec:
    raw = {
        "name": "p", "scenario": "s.yaml", "replicates": 2,
        "cases": [{"label": "a", "values": {"size": 1}}, {"label": "b", "set": {"actuator_faults": []}}],
        "grid": {"terms.1.onset": [0.3, 0.4]},
        "samples": {"runs": 3, "method": "random", "fields": {
            "parameters.size": {"uniform": [0.0, 1.0]},
            "variants.hs.controller.gains.mu": {"log_uniform": [0.1, 1.0],
                                                "also": ["variants.tosmo.controller.gains.mu"]}}},
    }
    raw.update(changes)
    return CampaignSpec.model_validate(raw)


def test_size_order_and_seeds():
    runs = population(spec(), base_seed=10)
    assert len(runs) == 3 * 2 * 2 * 2  # samples x cases x grid x replicates
    assert [r.index for r in runs] == list(range(24))
    # Run k = ((s C + c) G + g) R + r; seed = base + s R + r: cases and grid points share seeds.
    for run in runs:
        s, rest = divmod(run.index, 8)
        c, rest = divmod(rest, 4)
        g, r = divmod(rest, 2)
        assert run.seed == 10 + s * 2 + r
        assert run.case == "ab"[c] and run.values["terms.1.onset"] == [0.3, 0.4][g]
    assert len({r.run_id for r in runs}) == 24


def test_case_draws_give_each_case_its_own_seeds_and_sampled_points():
    runs = population(spec(case_draws=True), base_seed=10)
    for run in runs:
        s, rest = divmod(run.index, 8)
        c, rest = divmod(rest, 4)
        g, r = divmod(rest, 2)
        assert run.seed == 10 + (s * 2 + c) * 2 + r
    by_case = {case: [r for r in runs if r.case == case] for case in "ab"}
    assert not {r.seed for r in by_case["a"]} & {r.seed for r in by_case["b"]}
    sizes = {case: {r.values["parameters.size"] for r in rs} for case, rs in by_case.items()}
    assert len(sizes["a"]) == 3 and not sizes["a"] & sizes["b"]  # the cases' sampled values are their own
    shared = population(spec(), base_seed=10)
    assert [r.values["parameters.size"] for r in shared if r.case == "a"] == \
        [r.values["parameters.size"] for r in shared if r.case == "b"]  # common random numbers by default


def test_batchable_fields_go_to_the_member_and_the_rest_to_the_structure():
    run = population(spec(), base_seed=0)[0]
    assert run.member.keys() == {"seed", "parameters.size", "variants.hs.controller.gains.mu",
                                 "variants.tosmo.controller.gains.mu"}
    assert run.member["variants.hs.controller.gains.mu"] == run.member["variants.tosmo.controller.gains.mu"]
    assert run.structure == {"terms.1.onset": 0.3}
    other_case = next(r for r in population(spec(), base_seed=0) if r.case == "b")
    assert other_case.structure == {"actuator_faults": [], "terms.1.onset": 0.3}
    assert other_case.group != run.group
    assert run.columns()["case"] == "a" and run.columns()["size"] == 1


def test_the_first_runs_do_not_depend_on_the_population_size():
    for method in ("random", "sobol", "halton"):
        small = spec(samples={**spec().samples.model_dump(), "method": method, "runs": 2})
        large = spec(samples={**spec().samples.model_dump(), "method": method, "runs": 7})
        a, b = population(small, 0), population(large, 0)
        assert [r.run_id for r in a] == [r.run_id for r in b[:len(a)]], method
        assert [r.values for r in a] == [r.values for r in b[:len(a)]], method


def test_run_ids_are_the_content():
    a = population(spec(), base_seed=0)
    again = population(spec(description="other words"), base_seed=0)
    assert [r.run_id for r in a] == [r.run_id for r in again]
    other = population(spec(set={"sensors.position.noise_std": 1e-4}), base_seed=0)
    assert not {r.run_id for r in a} & {r.run_id for r in other}


def test_the_split_follows_the_declared_batchable_fields():
    grid = {"variants.hs.observer_initial.qd_hat.0": [0.0], "plant.mass_scale": [1.1], "initial.q.2": [0.1],
            "variants.hs.observer.type": ["eso"], "initial.q.x": [0.0], "sensors.position.noise_std": [0.1]}
    run = population(spec(grid=grid, samples=None, cases=[]), base_seed=0)[0]
    assert run.member.keys() == {"seed", "variants.hs.observer_initial.qd_hat.0", "plant.mass_scale", "initial.q.2"}
    assert run.structure == {"variants.hs.observer.type": "eso", "initial.q.x": 0.0, "sensors.position.noise_std": 0.1}
