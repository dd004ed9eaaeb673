from inkray.input.annotations import parse_annotations
from inkray.input.constraints import constraints


def test_records_carry_points_and_key_paths_in_entry_order():
    ann = parse_annotations({"format": "inkray-annotations", "version": 1, "size": [20, 20],
                             "order": [{"front": [1, 2], "back": [3, 4]},
                                       {"front": [5.5, 6], "back": [7, 8]}],
                             "equal": [{"a": [9, 9], "b": [10, 11]}]})
    got = constraints(ann)
    assert [c.key for c in got] == ["order[0]", "order[1]", "equal[0]"]
    assert got[1].first == (5.5, 6.0) and got[1].second == (7.0, 8.0)
    assert got[2].ends == ("a", "b") and got[0].ends == ("front", "back")
