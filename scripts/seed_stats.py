"""Mean and spread over seeds: the one home of this helper for the analysis scripts
(paired_gains.py, ablation_table.py, features_across.py)."""

import math
import statistics


def mean_std(values):
    """(mean, sample standard deviation) of a list of numbers: (None, None) for an empty list, and
    the std None for one value (one seed gives no spread). A NaN in the list makes both NaN: callers
    that mean to leave non-finite values out do so themselves and say how many they kept."""
    values = [float(v) for v in values]
    if not values:
        return None, None
    if len(values) == 1:
        return values[0], None
    return statistics.fmean(values), statistics.stdev(values)


def finite_mean_std(values):
    """mean_std of the finite values among `values` (None entries too are left out), and how many
    those are: (mean, std, count)."""
    kept = [v for v in values if v is not None and math.isfinite(v)]
    return mean_std(kept) + (len(kept),)


def std_text(std, digits):
    """A std as text: "n/a" when there is none (one seed)."""
    return 'n/a' if std is None else f'{std:.{digits}f}'
