"""The whitelisting parser of the on-site perturbation R (grammar in expression.py): the names R may use
(names.py), its tokens and their one-line messages (tokens.py), the recursive-descent parser (parser.py)
and the entry points (expression.py). User text never reaches eval, exec, sympify or parse_expr."""

from .expression import (bound_size, check_parameter_name, failing_term, formula, free_names, is_polynomial_in_state,
                         parse_expression, singular_terms)
from .names import (CONTACT_SYMBOLS, FUNCTIONS, MAX_DECIMAL_EXPONENT, MAX_DEPTH, MAX_EXPONENT, MAX_LENGTH, MAX_NODES,
                    MAX_POWER_BITS, MAX_TERMS, NON_SMOOTH,
                    RESERVED, SYMBOLS, ExpressionError, UserSymbol, symbol)

__all__ = [
    "CONTACT_SYMBOLS",
    "ExpressionError",
    "FUNCTIONS",
    "MAX_DECIMAL_EXPONENT",
    "MAX_DEPTH",
    "MAX_EXPONENT",
    "MAX_LENGTH",
    "MAX_NODES",
    "MAX_POWER_BITS",
    "MAX_TERMS",
    "NON_SMOOTH",
    "RESERVED",
    "SYMBOLS",
    "UserSymbol",
    "bound_size",
    "check_parameter_name",
    "failing_term",
    "formula",
    "free_names",
    "is_polynomial_in_state",
    "parse_expression",
    "singular_terms",
    "symbol",
]
