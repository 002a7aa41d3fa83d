"""Messages and generated files name an arm with the article it is spoken with."""

import pytest

from calibrator.inputs.messages import a_or_an


@pytest.mark.parametrize(
    ("name", "said"),
    [
        ("abb-irb4600-60-205", "an abb-irb4600-60-205"),
        ("er10l-c10", "an er10l-c10"),
        ("irb2400.urdf", "an irb2400.urdf"),
        ("ur10e", "a ur10e"),
        ("kuka-kr6-r900", "a kuka-kr6-r900"),
        ("fanuc-m20ia", "a fanuc-m20ia"),
        ("", "a "),
    ],
)
def test_an_arm_is_named_with_its_article(name, said):
    assert a_or_an(name) == said
