"""The paper's experiments: trajectory extraction and export, transfer, the demo, figures."""
