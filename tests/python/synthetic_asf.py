"""Synthetic Acclaim ASF skeletons for the motion tests (Y up, facing +Z, left = +X): one writer for the header, the
bone data and the hierarchy, so each test states only its bones and links."""


def asf_text(bones, hierarchy):
    """bones: (name, direction "x y z", length, axis "rx ry rz") each with rx ry rz DOFs; hierarchy: "parent child ..."
    lines, the root's first."""
    data = "\n".join(f" begin\n  id {i + 1}\n  name {n}\n  direction {d}\n  length {length}\n  axis {a} XYZ\n"
                     f"  dof rx ry rz\n end" for i, (n, d, length, a) in enumerate(bones))
    links = "".join(f"  {line}\n" for line in hierarchy)
    return (":version 1.10\n:name test\n:units\n  length 1.0\n  angle deg\n"
            ":root\n   order TX TY TZ RX RY RZ\n   axis XYZ\n   position 0 0 0\n   orientation 0 0 0\n"
            f":bonedata\n{data}\n:hierarchy\n begin\n{links} end\n")
