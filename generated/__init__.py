"""Python modules written by ``derive.codegen``. Never edit by hand."""
