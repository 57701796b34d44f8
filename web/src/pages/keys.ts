// API keys: sign in by pasting a key (kept in localStorage); list, create and revoke keys where the server allows.
import { ApiError, api, type ApiKey } from "../api/client";
import { clearKey, getKey, setKey } from "../api/session";
import { h, replace } from "../ui/dom";
import { dateTime } from "../ui/format";
import { refreshWho } from "../ui/who";

function localKeyHelp(): HTMLElement {
  return h("div", { class: "notice", id: "local-key-help" },
    h("strong", {}, "Running the embedded default? "),
    "On its first start, ", h("code", {}, "rigforge serve"), " creates a key named ", h("em", {}, "local"),
    ", prints it in its output, and keeps it in ", h("code", {}, ".rigforge/local-api-key"),
    " (inside ", h("code", {}, "RIGFORGE_DATA_DIR"), " when that is set). Read it with ",
    h("code", {}, "cat .rigforge/local-api-key"), ". On a shared server, ask an administrator for a key (",
    h("code", {}, "rigforge keys create --name you"), ").");
}

export function keysPage(root: HTMLElement): void {
  renderKeys(root, null);
}

function renderKeys(root: HTMLElement, message: Node | null): void {
  const input = h("input", { type: "password", id: "api-key", autocomplete: "off", spellcheck: false, placeholder: "rf_…", size: 48 });
  const msg = h("div", { role: "alert", id: "signin-message" }, message);
  const manage = h("section", { "aria-labelledby": "manage-title" });

  const signIn = h("form", { class: "panel", id: "signin-form" },
    h("div", { class: "row" }, h("label", { for: "api-key" }, "API key"), input,
      h("button", { type: "submit", class: "primary" }, "Sign in"),
      getKey() ? h("button", { type: "button", id: "sign-out", onclick: () => { clearKey(); refreshWho(); renderKeys(root, null); } }, "Sign out") : null),
    msg);
  signIn.addEventListener("submit", async (e) => {
    e.preventDefault();
    const secret = input.value.trim();
    if (!secret) { replace(msg, h("p", { class: "error" }, "paste a key first")); return; }
    try {
      const me = await api.whoami(secret);
      setKey(secret);
      await refreshWho();
      renderKeys(root, h("p", {}, `Signed in as ${me.name}. `, h("a", { href: "#/jobs" }, "Go to your jobs →")));
    } catch (err) {
      replace(msg, h("p", { class: "error" }, err instanceof ApiError ? `${err.code}: ${err.message}` : String(err)));
    }
  });

  async function renderManage(): Promise<void> {
    if (!getKey()) { manage.replaceChildren(); return; }
    let keys: ApiKey[];
    try {
      keys = await api.listKeys();
    } catch (err) {
      const forbidden = err instanceof ApiError && err.status === 403;
      replace(manage, h("h2", { id: "manage-title" }, "Manage keys"),
        h("p", { class: "muted" }, forbidden ? "This server manages keys on the command line (rigforge keys create | list | revoke)."
          : `could not list keys: ${err instanceof Error ? err.message : err}`));
      return;
    }
    const me = await api.whoami().catch(() => null);
    const name = h("input", { type: "text", id: "new-key-name", placeholder: "e.g. render farm", maxlength: 200 });
    const created = h("div", { role: "status" });
    const createForm = h("form", { class: "row", id: "create-key-form" }, h("label", { for: "new-key-name" }, "New key for"), name,
      h("button", { type: "submit" }, "Create key"));
    createForm.addEventListener("submit", async (e) => {
      e.preventDefault();
      try {
        const res = await api.createKey({ name: name.value, admin: false });
        await renderManage();
        replace(manage.querySelector("[role=status]")!, h("div", { class: "notice" }, `Key for ${res.key.name} (copy it now, it is not shown again): `,
          h("code", { id: "new-key-secret" }, res.secret)));
      } catch (err) {
        replace(created, h("p", { class: "error" }, err instanceof ApiError ? `${err.code}: ${err.message}` : String(err)));
      }
    });
    const rows = keys.map((k) => h("tr", {},
      h("td", {}, k.name, me && me.id === k.id ? h("span", { class: "muted" }, " (this browser)") : null),
      h("td", {}, h("code", {}, `${k.prefix}…`)),
      h("td", {}, dateTime(k.created_at)),
      h("td", {}, k.revoked_at ? `revoked ${dateTime(k.revoked_at)}` : "active"),
      h("td", {}, k.revoked_at ? null : h("button", { class: "danger", "aria-label": `Revoke key ${k.name}`, onclick: async () => {
        if (me && me.id === k.id && !confirm("This is the key this browser is signed in with. Revoke it anyway?")) return;
        await api.revokeKey(k.id).catch(() => null);
        renderManage();
      } }, "Revoke"))));
    replace(manage, h("h2", { id: "manage-title" }, "Manage keys"),
      h("table", { id: "keys-table" }, h("thead", {}, h("tr", {}, h("th", {}, "Name"), h("th", {}, "Prefix"), h("th", {}, "Created"), h("th", {}, "State"), h("th", {}))),
        h("tbody", {}, ...rows)),
      h("div", { style: "margin-top:10px" }, createForm), created);
  }

  replace(root, h("h1", {}, "API keys"), signIn, localKeyHelp(), manage);
  renderManage();
  if (!message) input.focus();
}
