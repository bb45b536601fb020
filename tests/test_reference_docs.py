"""The generated reference pages (docs/reference/configuration.md, cli.md) say what the code accepts: a change
of a configuration key, a default, a range or a command-line option without regenerating them fails here."""

from pathlib import Path

from optimizer.reference import PAGES, REGENERATE, configuration_markdown, render, stale

ROOT = Path(__file__).resolve().parents[1]


def test_the_generated_reference_pages_are_current():
    assert not stale(ROOT), f"stale reference pages: {', '.join(map(str, stale(ROOT)))}; run `{REGENERATE}`"


def test_every_configuration_key_is_on_the_page_with_its_default_and_range():
    from optimizer.campaign.config import CampaignConfig

    page = configuration_markdown()
    assert "| `max_iter` | integer | `2000` | [1, 100000] |" in page
    assert "| `timeout` | number | `1800.0` | (0, ∞) s |" in page
    for section in CampaignConfig.model_fields:
        assert f"## {section}\n" in page, section


def test_every_command_and_option_is_on_the_page():
    from optimizer.cli import build_parser

    page = render()[PAGES["cli"]]
    sub = next(a for a in build_parser()._actions if a.choices and hasattr(a, "_name_parser_map"))
    for name, command in sub.choices.items():
        assert f"## millfoil {name}\n" in page
        for action in command._actions:
            for flag in action.option_strings if action.dest != "help" else ():
                assert flag in page, (name, flag)
