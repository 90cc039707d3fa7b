"""Reports: tidy CSVs, the HTML report, plots and pictures. Never measures."""
