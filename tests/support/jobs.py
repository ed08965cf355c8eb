"""The head of the test jobs (``process JOB.toml``): the demo blisk part (mesh resolution
0.3 mm, Ti-6Al-4V), the stock and the machine with the LinuxCNC post; each test appends its
tools and operations."""


def demo_job_head(*, blank: str = "allowance:0.6", resolution: float = 1.0) -> str:
    """The TOML text of [part], [stock] (``blank``, ``resolution`` mm) and [machine]."""
    return f"""
[part]
source = "demo"
material = "Ti-6Al-4V"
[part.demo]
resolution = 0.3

[stock]
blank = "{blank}"
resolution = {resolution}

[machine]
name = "ac-trunnion"
posts = ["linuxcnc"]
"""
