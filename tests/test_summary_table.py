"""The printed summary table shows only the columns and rows a run has
(jaxdpd.analysis.summary_table, jaxdpd.run.runner.RunSummary.table)."""

from jaxdpd.run.runner import RunSummary

AVERAGES = {"temperature": (1.0, 0.01), "pressure": (23.7, 0.1)}


def test_a_fluid_of_one_chunk_has_no_ideal_chain_column_and_no_nan_rate():
    lines = RunSummary(None, 50, 1.0, averages=AVERAGES).table().splitlines()
    assert lines[0].split() == ["observable", "mean", "±", "s.e.", "unit"]
    assert [line.split()[0] for line in lines[1:]] == ["temperature", "pressure"]
    assert "nan" not in "\n".join(lines)


def test_chains_get_the_ideal_chain_column_and_two_chunks_a_rate():
    summary = RunSummary(
        None,
        200,
        1.0,
        steady_rate=1.5e5,
        averages={"a/bond_length_sq": (0.98, 0.003), **AVERAGES},
        references={"a/bond_length_sq": 0.872727},
    )
    lines = summary.table().splitlines()
    assert lines[0].endswith("ideal chain")
    assert lines[1].split()[-1] == "0.872727"
    assert lines[-1].startswith("particle-steps/s") and "1.5e+05" in lines[-1]
