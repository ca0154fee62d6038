"""The snake2010 real-time block read: a 4-quadlet header, then one word per channel for
each of ADC, encoder, encoder period and (unimplemented) encoder frequency, the four
devices of thesis Table 1 that a block read carries; 32 quadlets for 7 channels. Every
quadlet of the block belongs to exactly one of them."""

from __future__ import annotations

import pytest

from fw1394.boards.snake2010.spec import (
    RT_HEADER_QUADLETS,
    rt_adc_index,
    rt_encoder_index,
    rt_frequency_index,
    rt_period_index,
    rt_read_quadlets,
)


def test_seven_channels_read_32_quadlets() -> None:
    assert rt_read_quadlets(7) == 32


@pytest.mark.parametrize("channels", range(1, 16))
def test_every_quadlet_of_the_block_has_exactly_one_owner(channels: int) -> None:
    owners = list(range(RT_HEADER_QUADLETS))
    for channel in range(1, channels + 1):
        owners += [
            rt_adc_index(channel),
            rt_encoder_index(channel, channels),
            rt_period_index(channel, channels),
            rt_frequency_index(channel, channels),
        ]
    assert sorted(owners) == list(range(rt_read_quadlets(channels)))
