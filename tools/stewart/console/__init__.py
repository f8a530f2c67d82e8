# SPDX-License-Identifier: Apache-2.0
"""``stewart console``: the operator's console in the browser.

- :mod:`.validate` checks the API's command payloads;
- :mod:`.hub` is the bus side: the operator node every client shares, who
  commands, the snapshots, the UDP pose output;
- :mod:`.recorder` records the buses and analyses a finished recording;
- :mod:`.server` is the HTTP + WebSocket server (aiohttp) and the page.
"""
