// The "signed in as …" line in the header.
import { api } from "../api/client";
import { getKey } from "../api/session";

export async function refreshWho(): Promise<void> {
  const who = document.getElementById("who")!;
  if (!getKey()) { who.textContent = "not signed in"; return; }
  try {
    const me = await api.whoami();
    who.textContent = `signed in as ${me.name} (${me.prefix}…)`;
  } catch {
    who.textContent = "key not accepted";
  }
}
