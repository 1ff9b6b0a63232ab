import pytest

from meshes import FAMILIES


@pytest.fixture(params=list(FAMILIES))
def family(request):
    make_mesh, elem = FAMILIES[request.param]
    return request.param, make_mesh(), elem()
