"""Helpers shared by the benchmarks: aligned tables, section headings, least-disturbed timing."""
import time


def table(headers: list[str], rows: list[list[str]]) -> str:
    """Right-aligned columns (the first column left-aligned)."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]

    def line(cells):
        return "  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths)))
    return "\n".join([line(headers), line(["-" * w for w in widths])] + [line(r) for r in rows])


def heading(text: str) -> None:
    print(f"\n{text}\n{'=' * len(text)}")


def best_of(function, *args, repeats=5):
    """Smallest wall time of `repeats` calls (the machine is shared: the minimum is the least disturbed)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function(*args)
        times.append(time.perf_counter() - start)
    return min(times)


def build_and_load_times(table_for, *args, **kwargs):
    """(table, build time, load time): `table_for(*args, **kwargs)` into an empty cache, then again from it."""
    start = time.perf_counter()
    table = table_for(*args, **kwargs)
    build = time.perf_counter() - start
    start = time.perf_counter()
    table_for(*args, **kwargs)
    return table, build, time.perf_counter() - start
