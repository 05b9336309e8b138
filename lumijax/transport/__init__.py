"""Form factors and the block-sparse transport operator (see ``docs/radiosity.md``)."""

from ._build import FormFactorSettings as FormFactorSettings, build_operator as build_operator
from ._kernels import (
    form_factor_far as form_factor_far,
    form_factor_point_triangle as form_factor_point_triangle,
)
from ._operator import (
    Bucket as Bucket,
    LowRankBucket as LowRankBucket,
    ReflectionOperator as ReflectionOperator,
    TransportOperator as TransportOperator,
    load_operator as load_operator,
)
from ._store import (
    FORMAT as FORMAT,
    OperatorFileError as OperatorFileError,
    cache_path as cache_path,
    cached_operator as cached_operator,
    operator_key as operator_key,
)
