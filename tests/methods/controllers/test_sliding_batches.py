"""Batch against single for the dissertation's sliding-mode laws (SMC, NTSMC, NFTSMC, sigmoid NFTSMC): B members
with their own gains give member by member the bits of B single-member laws. A reduction over the wrong axis
(e^T e summed over the members as well as the joints) or a lost ``keepdims`` fails it."""

from __future__ import annotations

import pytest
from controller_batch import assert_batch_equals_single

from ftc_mj.methods.controllers import NFTSMC, NTSMC, SMC, SigmoidNFTSMC

LAWS = {
    SMC: dict(c=5.0, bound=0.5, mu=0.5),
    NTSMC: dict(beta1=5.0, beta2=0.4, decay=0.7, alpha=0.3, bound=0.5, mu=0.5),
    NFTSMC: dict(beta1=15.0, beta2=10.0, beta3=10.0, beta4=5.0, gamma1=0.5, bound=0.5, mu=0.5),
    SigmoidNFTSMC: dict(kappa1=2.0, kappa2=1.5, mu1=1.2, mu2=1.4, alpha=0.6, bound=0.5, mu=0.5),
}


@pytest.mark.parametrize("law", list(LAWS), ids=lambda cls: cls.name)
def test_batch_equals_single_member_by_member(law):
    gains = LAWS[law]
    members = [{**gains, "bound": gains["bound"] * (1 + m)} for m in range(4)]
    assert_batch_equals_single(law, members, periods=50)
    assert_batch_equals_single(law, [gains, gains], n=4, periods=50, scale=5.0)
