"""The benchmark floor: what turns evaluation records into figures a paper can cite (statistics with
their intervals, paired comparisons of two reports, robustness curves and tables)."""
