"""Mean and spread over seeds: the one home of this helper for the analysis scripts
(paired_gains.py, ablation_table.py, features_across.py)."""

import math


def mean_std(values):
    """(mean, sample standard deviation, n - 1 in the denominator) of a list of numbers: (None, None)
    for an empty list, and the std None for one value (one seed gives no spread). A NaN or an
    infinity in the list makes the std NaN (and the mean NaN or infinite), never an error: callers
    that mean to leave non-finite values out do so themselves and say how many they kept."""
    values = [float(v) for v in values]
    if not values:
        return None, None
    mean = math.fsum(values) / len(values)
    if len(values) == 1:
        return mean, None
    if not all(math.isfinite(v) for v in values):
        return mean, math.nan
    return mean, math.sqrt(math.fsum((v - mean) ** 2 for v in values) / (len(values) - 1))


def finite_mean_std(values):
    """mean_std of the finite values among `values` (None entries too are left out), and how many
    those are: (mean, std, count)."""
    kept = [v for v in values if v is not None and math.isfinite(v)]
    return mean_std(kept) + (len(kept),)


def std_text(std, digits, missing='n/a'):
    """A std as text: `missing` when there is none (one seed; tables say "n/a", CSVs leave it
    empty)."""
    return missing if std is None else f'{std:.{digits}f}'
