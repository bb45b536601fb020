"""The generated reference pages (docs/reference/configuration.md, cli.md) say what the code accepts: a change
of a configuration key, a default, a range or a command-line option without regenerating them fails here."""

import argparse
from pathlib import Path

from optimizer.reference import PAGES, REGENERATE, cli_markdown, configuration_markdown, stale

ROOT = Path(__file__).resolve().parents[1]


def test_the_generated_reference_pages_are_current():
    old = stale(ROOT)
    assert not old, f"stale reference pages: {', '.join(map(str, old))}; regenerate them with `{REGENERATE}`"


def test_stale_names_a_page_that_differs(tmp_path):
    """A page missing or edited by hand is stale; the pages the generator writes are not."""
    assert stale(tmp_path) == list(PAGES.values())
    for path, text in ((PAGES["configuration"], configuration_markdown()), (PAGES["cli"], cli_markdown())):
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text, encoding="utf-8")
    assert stale(tmp_path) == []
    (tmp_path / PAGES["cli"]).write_text(cli_markdown().replace("--json", "--jsn"), encoding="utf-8")
    assert stale(tmp_path) == [PAGES["cli"]]


def test_every_configuration_key_is_on_the_page_with_its_default_and_range():
    from optimizer.campaign.config import CampaignConfig
    from optimizer.config import Config

    page = configuration_markdown()
    assert "| `max_iter` | integer | `2000` | [1, 100000] |" in page
    assert "| `timeout` | number | `1800.0` | (0, inf) s |" in page
    assert "| `upstream` | number or null | `null` | (0, 100] chords |" in page
    for section in CampaignConfig.model_fields:
        assert f"## {section}\n" in page, section
    # the sections of an evaluate file are the campaign file's, so one table each says both
    for section, info in Config.model_fields.items():
        assert CampaignConfig.model_fields[section].annotation is info.annotation, section


def test_the_blade_parameters_of_each_family_are_on_the_page():
    from geometry import Continuity, Mode, parameters_of

    page = configuration_markdown()
    for mode in Mode:
        table = page.split(f"\n### {mode.value} blades\n", 1)[1].split("\n#", 1)[0]
        for continuity in Continuity:
            for name in parameters_of(mode, continuity):
                assert f"| `{name}` |" in table, (mode, name)
    assert "| `alpha` | deg | [-90, 90] | [-5, 25] | chord angle α | all |" in page


def test_every_command_and_option_is_on_the_page():
    from optimizer.cli import build_parser

    page = cli_markdown()
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name, command in sub.choices.items():
        assert f"## millfoil {name}\n" in page
        section = page.split(f"## millfoil {name}\n", 1)[1].split("\n## ", 1)[0]
        for action in command._actions:
            if not isinstance(action, argparse._HelpAction):
                assert f"| `{', '.join(action.option_strings) or action.metavar or action.dest}` |" in section, \
                    (name, action.dest)


def test_usage_is_wrapped_by_the_generator_not_by_argparse():
    """argparse's wrapping of a long usage differs between Python versions; the page's does not: every line
    fits the width and an option stays on its line with its value."""
    from optimizer.reference import USAGE_WIDTH

    page = cli_markdown()
    usages = [block.split("\n```", 1)[0] for block in page.split("```text\nusage: ")[1:]]
    assert len(usages) > 5
    for usage in usages:
        assert all(len(line) <= USAGE_WIDTH for line in f"usage: {usage}".splitlines()), usage
    assert "\n                       --format {csv,dxf,linuxcnc,sinumerik} [--out FILE]" in page
