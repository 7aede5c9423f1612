"""summary(model): one screen naming the elements, sizes, parameters and outputs."""

from __future__ import annotations

from pathlib import Path

from depsim.dsl import load_model, parse_model, summary, with_elements

EXAMPLES = Path(__file__).parents[2] / "examples"


def test_intelsat5_summary():
    text = summary(load_model(EXAMPLES / "intelsat5.dep"))
    lines = text.splitlines()
    assert lines[0] == ("model intelsat5: INTELSAT V solar-array deployment: yoke and three "
                        "panels, Z-folded")
    assert "bodies (4)" in lines and "hinges (4)" in lines and "cables (3)" in lines
    assert any(line.startswith("  h3") and "theta = -(panel2 - panel1) + 180 deg" in line
               for line in lines)
    assert "latch 90 deg" in text and "friction 0.68 N*m" in text
    assert "  loop1        stiffness 1.515 N*m/rad, angles 2*h1 - h2" in lines
    assert ("coordinates 12 (3 per rigid body); constraints 8 (2 per hinge or slider); "
            "degrees of freedom 4") in lines
    assert "  cable_k = 4500 N/m" in lines
    assert "outputs (4): theta1 [rad], theta2 [rad], theta3 [rad], theta4 [rad]" in lines
    assert lines[-1] == "warnings: none"
    assert max(len(line) for line in lines) <= 100 and len(lines) <= 60


def test_slider_crank_summary_shows_the_assembly_and_loop():
    text = summary(load_model(EXAMPLES / "slider_crank.dep"))
    assert "assembly: crank_pin places crank, guide places piston, wrist places rod" in text
    assert "loops closed by: gudgeon" in text
    assert "degrees of freedom 1" in text
    assert "wrist.initial_angle (from r, l)" in text


def test_beam_model_reports_beam_coordinates_without_dof():
    text = summary(load_model(EXAMPLES / "two_link_flex.dep"))
    assert "beam coordinates (set by the beam element)" in text
    assert "degrees of freedom" not in text
    assert "2 elements" in text
    one = summary(with_elements(load_model(EXAMPLES / "two_link_flex.dep"), {"link1": 1}))
    assert "5 kg/m, 1 element\n" in one and "1 elements" not in one


def test_warnings_are_listed():
    model = parse_model("model m\nbar b { length = 1 m; mass = 1 kg; inertia = 1 kg*m^2 }\n",
                        "w.dep")
    assert "warnings (1):\n  w.dep:2:5: warning[W001]: bar 'b' has no joint path" \
        in summary(model)
