"""Reports: figures in the thesis style, HTML and Markdown reports."""
